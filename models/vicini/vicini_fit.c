/* `vicini`: maximum-likelihood density and mix from free flights (vicini_fit.h). In double: the
 * likelihood sums a few hundred logarithms and the searches compare their slopes.
 *
 * For a fixed density every flight's likelihood is affine in gamma (gamma times its exponential
 * term plus (1 - gamma) times its linear term), so L is concave in gamma and its best gamma is a
 * one-dimensional concave maximisation needing no new exponentials. The search is therefore over
 * the density: the profile L*(rho) = max_gamma L(rho, gamma) is scanned at densities a factor 2
 * apart, and around the best scan point the zero of its slope is found by bisection (by the envelope
 * theorem, the slope of L* is dL/drho at the best gamma). */
#include <math.h>
#include <stdlib.h>

#include "vicini_fit.h"

#define SCAN_FACTOR 2.0    /* scan densities a factor 2 apart */
#define BISECTION_STEPS 12 /* over a factor 4: 2^-12 of it, far below the record's code step (4.5 %) */
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
    for (int i = 0; i < GAMMA_STEPS && hi - lo > 1e-6; i++) {
        double s = gamma_slope(t, n, g, &c);
        if (s > 0.0)
            lo = g;
        else
            hi = g;
        double next = c < 0.0 ? g - s / c : 0.5 * (lo + hi);
        g = next > lo && next < hi ? next : 0.5 * (lo + hi);
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

/* The profile at rho: its best gamma, L there and dL/drho there (-INFINITY beyond the possible). */
typedef struct {
    double gamma, ll, slope;
} profile_point;

static void profile(const vicini_flight *f, int n, double rho, terms *t, int want_ll, profile_point *p)
{
    fill_terms(f, n, rho, t);
    if (!possible(t, n)) {
        p->gamma = 1.0, p->ll = -INFINITY, p->slope = -INFINITY;
        return;
    }
    double g = best_gamma(t, n), ll = 0.0, slope = 0.0;
    for (int i = 0; i < n; i++) {
        double x = (double)f[i].x, tau = rho * x, e = g * t->ex[i];
        double p_i = t->lin[i] + g * (t->ex[i] - t->lin[i]);
        if (!(p_i > 0.0)) {
            p->gamma = g, p->ll = -INFINITY, p->slope = -INFINITY;
            return;
        }
        if (f[i].collided) {
            slope += 1.0 / rho - x * e / p_i; /* d/drho [log rho + log g(rho x)] */
            if (want_ll)
                ll += log(rho * p_i);
        } else {
            slope -= x * (e + (tau < 2.0 ? 0.5 * (1.0 - g) : 0.0)) / p_i; /* d/drho log f(rho x) */
            if (want_ll)
                ll += log(p_i);
        }
    }
    p->gamma = g, p->ll = ll, p->slope = slope;
}

void vicini_fit(const vicini_flight *f, int n, double rho_min, double rho_max, vicini_estimate *out)
{
    int collided = 0;
    for (int i = 0; i < n; i++)
        collided += f[i].collided != 0;
    out->density = 0.0, out->gamma = 1.0, out->log_likelihood = 0.0;
    if (!collided)
        return;
    double stack[2 * STACK_FLIGHTS];
    double *mem = n <= STACK_FLIGHTS ? stack : malloc(2 * (size_t)n * sizeof *mem);
    if (!mem)
        return; /* out of memory for an oversized sample count: left empty */
    terms t = {mem, mem + n};

    /* Scan. */
    double best_rho = rho_min;
    profile_point best = {1.0, -INFINITY, 0.0};
    for (double rho = rho_min; rho <= rho_max * 1.0000001; rho *= SCAN_FACTOR) {
        profile_point p;
        profile(f, n, rho, &t, 1, &p);
        if (p.ll > best.ll)
            best = p, best_rho = rho;
    }
    /* Refine: the zero of the slope between the best scan point's neighbours. */
    double a = fmax(best_rho / SCAN_FACTOR, rho_min), b = fmin(best_rho * SCAN_FACTOR, rho_max);
    profile_point pa, pb;
    profile(f, n, a, &t, 0, &pa);
    profile(f, n, b, &t, 0, &pb);
    if (pa.slope > 0.0 && !(pb.slope > 0.0)) {
        double la = log(a), lb = log(b);
        for (int i = 0; i < BISECTION_STEPS; i++) {
            double m = 0.5 * (la + lb);
            profile_point pm;
            profile(f, n, exp(m), &t, 0, &pm);
            if (pm.slope > 0.0)
                la = m;
            else
                lb = m;
        }
        /* The last density still rising is always possible; the first falling may lie past an
         * impossible flight: keep the better of the two. */
        profile_point p1, p2;
        profile(f, n, exp(la), &t, 1, &p1);
        profile(f, n, exp(lb), &t, 1, &p2);
        if (p1.ll > best.ll)
            best = p1, best_rho = exp(la);
        if (p2.ll > best.ll)
            best = p2, best_rho = exp(lb);
    }
    out->density = best_rho;
    out->gamma = best.gamma;
    out->log_likelihood = best.ll;
    if (mem != stack)
        free(mem);
}
