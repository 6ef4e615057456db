/* `vicini`: maximum-likelihood density and mix from free flights (vicini_fit.h). In double: the
 * likelihood sums a few hundred logarithms and the searches compare their slopes.
 *
 * For a fixed density every flight's likelihood is affine in gamma (gamma times its exponential
 * term plus (1 - gamma) times its linear term), so L is concave in gamma and its best gamma is a
 * one-dimensional concave maximisation needing no new exponentials. The density is then searched
 * over the candidates the record can store, on the profile L*(rho) = max_gamma L(rho, gamma):
 * every 16th candidate, then around the best every 4th within 12 and every one within 3. Not by
 * following the slope: the profile is a sawtooth, each flight whose depth passes the linear
 * part's reach (tau = 2) dropping it by a step, and its maximum often sits just before a step (for
 * a surface, gamma = 0 at the largest density every collision allows). */
#include <math.h>
#include <stdlib.h>

#include "vicini_fit.h"

#define SCAN_STRIDE 16 /* coarse scan: every 16th candidate density (a factor 2 on the record's codes) */
#define GAMMA_STEPS 40     /* safeguarded Newton on a concave function: a handful are used */
#define STACK_FLIGHTS 256

static double transmittance(double tau, double gamma)
{
    return gamma * exp(-tau) + (1.0 - gamma) * fmax(1.0 - 0.5 * tau, 0.0);
}

static double collision_density(double tau, double gamma)
{
    return gamma * exp(-tau) + (tau < 2.0 ? 0.5 * (1.0 - gamma) : 0.0);
}

double vicini_log_likelihood(const vicini_flight *f, int n, double rho, double gamma)
{
    double sum = 0.0;
    for (int i = 0; i < n; i++) {
        double tau = rho * (double)f[i].x;
        double p = f[i].collided ? rho * collision_density(tau, gamma) : transmittance(tau, gamma);
        if (!(p > 0.0))
            return -INFINITY;
        sum += log(p);
    }
    return sum;
}

/* One density's terms: flight i's likelihood is (rho if collided) (lin[i] + gamma (ex[i] - lin[i])). */
typedef struct {
    double *ex, *lin;
} terms;

static void fill_terms(const vicini_flight *f, int n, double rho, terms *t)
{
    for (int i = 0; i < n; i++) {
        double tau = rho * (double)f[i].x;
        t->ex[i] = exp(-tau);
        t->lin[i] = f[i].collided ? (tau < 2.0 ? 0.5 : 0.0) : fmax(1.0 - 0.5 * tau, 0.0);
    }
}

/* dL/dgamma at gamma (+INFINITY where a flight's likelihood is 0 at gamma and rises with it). */
static double gamma_slope(const terms *t, int n, double gamma, double *curvature)
{
    double s = 0.0, c = 0.0;
    for (int i = 0; i < n; i++) {
        double d = t->ex[i] - t->lin[i], p = t->lin[i] + gamma * d;
        if (!(p > 0.0)) {
            if (d > 0.0)
                return INFINITY;
            continue; /* impossible whatever gamma: the caller has ruled this density out */
        }
        s += d / p;
        c -= d * d / (p * p);
    }
    *curvature = c;
    return s;
}

/* The best gamma for one density (L is concave in gamma): 0 or 1 when the slope says so, else
 * Newton's method kept inside a shrinking bracket. */
static double best_gamma(const terms *t, int n)
{
    double c;
    if (gamma_slope(t, n, 1.0, &c) >= 0.0)
        return 1.0;
    if (gamma_slope(t, n, 0.0, &c) <= 0.0)
        return 0.0;
    double lo = 0.0, hi = 1.0, g = 0.5;
    for (int i = 0; i < GAMMA_STEPS; i++) {
        double s = gamma_slope(t, n, g, &c);
        if (s > 0.0)
            lo = g;
        else
            hi = g;
        double next = c < 0.0 ? g - s / c : 0.5 * (lo + hi);
        next = next > lo && next < hi ? next : 0.5 * (lo + hi);
        /* Converged far below the record's gamma step (1/127). */
        if (fabs(next - g) < 1e-6 || hi - lo < 1e-6)
            return next;
        g = next;
    }
    return g;
}

/* Whether every flight is possible at this density for some gamma. */
static int possible(const terms *t, int n)
{
    for (int i = 0; i < n; i++)
        if (!(t->ex[i] > 0.0) && !(t->lin[i] > 0.0))
            return 0;
    return 1;
}

/* The profile at rho: its best gamma and L there (-INFINITY where a flight is impossible). */
typedef struct {
    double gamma, ll;
} profile_point;

static void profile(const vicini_flight *f, int n, double rho, terms *t, profile_point *p)
{
    fill_terms(f, n, rho, t);
    if (!possible(t, n)) {
        p->gamma = 1.0, p->ll = -INFINITY;
        return;
    }
    /* The sum of logarithms as the logarithm of running products (a logarithm is most of a
     * profile's cost), taken whenever the product nears the bottom of double's range. */
    double g = best_gamma(t, n), ll = 0.0, prod = 1.0;
    for (int i = 0; i < n; i++) {
        double p_i = t->lin[i] + g * (t->ex[i] - t->lin[i]);
        if (!(p_i > 0.0)) {
            p->gamma = g, p->ll = -INFINITY;
            return;
        }
        prod *= f[i].collided ? rho * p_i : p_i;
        if (prod < 1e-250 || prod > 1e250) {
            ll += log(prod);
            prod = 1.0;
        }
    }
    p->gamma = g, p->ll = ll + log(prod);
}

void vicini_fit(const vicini_flight *f, int n, const double *densities, int count, vicini_estimate *out)
{
    int collided = 0;
    for (int i = 0; i < n; i++)
        collided += f[i].collided != 0;
    out->density = 0.0, out->gamma = 1.0, out->log_likelihood = 0.0;
    if (!collided || count <= 0)
        return;
    double stack[2 * STACK_FLIGHTS];
    double *mem = n <= STACK_FLIGHTS ? stack : malloc(2 * (size_t)n * sizeof *mem);
    if (!mem)
        return; /* out of memory for an oversized sample count: left empty */
    terms t = {mem, mem + n};
    profile_point best = {1.0, -INFINITY};
    int best_k = 0;
    /* Coarse: every SCAN_STRIDE-th density. Fine: every density within a stride of the best. */
    for (int k = 0; k < count; k += k + SCAN_STRIDE < count || k == count - 1 ? SCAN_STRIDE : count - 1 - k) {
        profile_point p;
        profile(f, n, densities[k], &t, &p);
        if (p.ll > best.ll)
            best = p, best_k = k;
    }
    /* Then around the best so far at strides 4 and 1: within 12 candidates, then within 3. */
    for (int stride = 4; stride >= 1; stride /= 4) {
        int centre = best_k;
        for (int d = -3; d <= 3; d++) {
            int k = centre + d * stride;
            if (d == 0 || k < 0 || k >= count)
                continue;
            profile_point p;
            profile(f, n, densities[k], &t, &p);
            if (p.ll > best.ll)
                best = p, best_k = k;
        }
    }
    out->density = densities[best_k];
    out->gamma = best.gamma;
    out->log_likelihood = best.ll;
    if (mem != stack)
        free(mem);
}
