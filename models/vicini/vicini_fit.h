/* `vicini` bake side: the maximum-likelihood fit of a voxel's density and transmittance mix from
 * the free flights of its sample rays (Vicini et al. 2021 fit the same two parameters by gradient
 * descent on rendered transmittance; with the rays' own free-flight distances the likelihood can
 * be maximised directly). Host C only.
 *
 * A flight is one sample ray's path through the voxel, measured in optical length per unit
 * density: x = sigma(w) d, d in voxel lengths and sigma(w) the SGGX projected area along the ray.
 * It either ended inside the voxel (a collision at x) or left it (censored: it got at least x
 * through). Under the model, the transmittance after optical depth tau = rho x is
 * f(tau, gamma) = gamma e^-tau + (1 - gamma) max(1 - tau/2, 0) and the collision density is
 * g = -df/dtau = gamma e^-tau + (1 - gamma)/2 [tau < 2], so the log-likelihood is
 *     L(rho, gamma) = sum_collided log(rho g(rho x)) + sum_censored log f(rho x).
 * For a fixed density the likelihood is concave in gamma (each flight's term is affine in it), so
 * the best gamma is cheap; the density is searched on that profile among the densities the record
 * can store (vicini_fit.c). A collision or a transit
 * beyond the linear part's reach, impossible under the model, rules a density out. Surface-like
 * voxels, whose flights all stop within a bounded depth, come out linear (gamma near 0); foliage, whose flights end at exponentially
 * distributed depths, exponential (gamma near 1). */
#ifndef VX_VICINI_FIT_H
#define VX_VICINI_FIT_H

typedef struct {
    float x;      /* optical length per unit density */
    int collided; /* 1: the flight ended at x; 0: it left the voxel after x */
} vicini_flight;

typedef struct {
    double density;        /* 0 when no flight collided */
    double gamma;          /* in [0, 1]; 1 when density is 0 */
    double log_likelihood; /* at (density, gamma) */
} vicini_estimate;

/* L(rho, gamma) as above (-INFINITY where the flights are impossible under the model). */
double vicini_log_likelihood(const vicini_flight *f, int n, double rho, double gamma);

/* The maximum-likelihood density among the candidates densities[0..count-1] (ascending, log
 * spaced: the values the record can store) and gamma in [0, 1]. */
void vicini_fit(const vicini_flight *f, int n, const double *densities, int count, vicini_estimate *out);

#endif
