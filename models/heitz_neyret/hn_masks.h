/* Coverage masks of a cone element (Heitz & Neyret 2012 §5.4, 2011 report appendix B): which of
 * 128 Poisson-disk sample positions omega of the element's footprint (the unit disk, in the ray's
 * frame) see the mean surface plane within the element. Portable C: reads the precomputed table
 * (a plain array behind VX_GLOBAL, a buffer under OpenCL) and never builds it.
 *
 * The table holds the half-plane masks omega.(cos t, sin t) <= v for 256 x 256 (t, v). In the
 * element's frame (x, y across the footprint, z along the ray, origin at the element's centre) a
 * plane x.n + D = 0 alone (D = signed distance of the centre above it) occupies the ray through
 * r omega when either end z = +-r (length = diameter) is below it:
 *   r omega.(nx, ny) - r |nz| + D <= 0  <=>  omega.(cos t, sin t) <= v = (r |nz| - D) / (r rho),
 * rho = sqrt(nx^2 + ny^2), t = atan2(ny, nx): the paper's mask. Several bounds at once (a plane,
 * where the surface ends, a sheet's other side) are one half-plane per pair of bounds
 * (hn_constraints_mask). */
#ifndef VX_HN_MASKS_H
#define VX_HN_MASKS_H

#include "hn_fastmath.h"
#include "model.h"

#define HN_MASK_SAMPLES 128
#define HN_TABLE_T 256 /* angle bins over [0, 2 pi), nearest */
#define HN_TABLE_V 256 /* offset bins over [-1, 1], nearest (bin centres) */
#define HN_TABLE_WORDS (HN_TABLE_T * HN_TABLE_V * VX_MASK_WORDS)

VX_INLINE void hn_mask_set(unsigned int *m, unsigned int value)
{
    for (int w = 0; w < VX_MASK_WORDS; w++)
        m[w] = value;
}

VX_INLINE int hn_mask_count(const unsigned int *m)
{
    int c = 0;
    for (int w = 0; w < VX_MASK_WORDS; w++) {
        unsigned int x = m[w];
        /* SWAR popcount: portable (OpenCL has popcount, plain C has not). */
        x = x - ((x >> 1) & 0x55555555u);
        x = (x & 0x33333333u) + ((x >> 2) & 0x33333333u);
        x = (x + (x >> 4)) & 0x0f0f0f0fu;
        c += (int)((x * 0x01010101u) >> 24);
    }
    return c;
}

/* The mask of omega.(cos t, sin t) <= v. v <= -1 covers nothing, v >= 1 everything (the samples lie
 * inside the unit disk); NaN covers nothing. */
VX_INLINE void hn_mask_lookup(VX_GLOBAL const unsigned int *table, float t, float v, unsigned int *out)
{
    if (!(v > -1.0f)) {
        hn_mask_set(out, 0u);
        return;
    }
    if (v >= 1.0f) {
        hn_mask_set(out, 0xffffffffu);
        return;
    }
    float ft = t * ((float)HN_TABLE_T / 6.28318530717958647692f);
    if (!(fabsf(ft) < 1e6f))
        ft = 0.0f;
    int ti = (int)floorf(ft + 0.5f) % HN_TABLE_T;
    if (ti < 0)
        ti += HN_TABLE_T;
    int vi = (int)((v + 1.0f) * (0.5f * (float)HN_TABLE_V));
    vi = vi < 0 ? 0 : (vi >= HN_TABLE_V ? HN_TABLE_V - 1 : vi);
    VX_GLOBAL const unsigned int *m = table + ((size_t)ti * HN_TABLE_V + (size_t)vi) * VX_MASK_WORDS;
    for (int w = 0; w < VX_MASK_WORDS; w++)
        out[w] = m[w];
}

/* A linear constraint on the element's rays: the point r omega + z e_z (omega in the unit disk across
 * the footprint, z along the ray) satisfies it when A + r omega.(cx, cy) + b z <= 0. */
typedef struct {
    float A, cx, cy, b;
} hn_constraint;

#define HN_CONSTRAINTS_MAX 4

/* The constraint set of hn_constraints_mask: the segment's own ends z <= r and -z <= r + behind,
 * then c[0 .. n - 1] (at most HN_CONSTRAINTS_MAX); returns how many. r and behind are clamped at 0
 * here, so every caller works with the same numbers. */
VX_INLINE int hn_constraints_all(const hn_constraint *c, int n, float *r, float *behind, hn_constraint *all)
{
    *r = vx_fmaxf(*r, 0.0f);
    *behind = vx_fmaxf(*behind, 0.0f);
    int count = 0;
    all[count].A = -*r, all[count].cx = 0.0f, all[count].cy = 0.0f, all[count].b = 1.0f, count++;
    all[count].A = -*r - *behind, all[count].cx = 0.0f, all[count].cy = 0.0f, all[count].b = -1.0f, count++;
    for (int i = 0; i < n && i < HN_CONSTRAINTS_MAX; i++)
        all[count++] = c[i];
    return count;
}

/* The half-plane in omega of upper bound p and lower bound q (see hn_constraints_mask): the rays
 * r omega with omega.(cx, cy)/|.| <= v, v returned, (*cx, *cy) its direction. v <= -1 (or NaN): no
 * ray; v >= 1: every ray. */
VX_INLINE float hn_constraint_pair(const hn_constraint *p, const hn_constraint *q, float r, float *cx, float *cy)
{
    float bp = p->b, bq = -q->b;
    float k = p->A * bq + q->A * bp;
    *cx = p->cx * bq + q->cx * bp;
    *cy = p->cy * bq + q->cy * bp;
    float den = r * sqrtf(*cx * *cx + *cy * *cy);
    /* All or nothing without the angle: most elements lie wholly inside or outside most bounds. */
    return den > 1e-30f ? -k / den : (k <= 0.0f ? 1.0f : -1.0f);
}

/* Whether (p, q), p an upper bound of hn_constraints_all's, is not a pair to test: q is an upper bound
 * too, or the two are the segment's own ends, which always agree. */
#define HN_PAIR_SKIPPED(all, p, q) ((all)[q].b > 0.0f || ((p) == 0 && (q) == 1))

/* The mask of the rays r omega whose segment z in [-r - behind, r] (the element's, extended toward
 * the viewer by `behind`) holds one point that meets every constraint at once. Why not the AND of one mask per constraint: each of those says
 * that *some* point of the segment meets it, and a ray passing beyond a tilted plate's far edge
 * has a point below the plate's plane (past the edge) and another inside the edge (above the
 * plane), so it was covered though no point of it touches the plate: about r tan(theta) of
 * silhouette swelling, tied to the pixel. The exact test eliminates z (Fourier-Motzkin): the
 * constraints are lower (b < 0) or upper (b > 0) bounds on z, and the segment holds a point iff
 * every lower bound lies below every upper bound; each such pair, and each constraint with b = 0,
 * is one half-plane in omega, A_p |b_q| + A_q |b_p| + r omega.(c_p |b_q| + c_q |b_p|) <= 0, read
 * from the table (hn_constraint_pair). The segment's own ends z <= r and -z <= r + behind are two of
 * the bounds. One empty pair empties the mask. */
VX_INLINE void hn_constraints_mask(VX_GLOBAL const unsigned int *table, const hn_constraint *c, int n, float r,
                                   float behind, unsigned int *out)
{
    hn_constraint all[HN_CONSTRAINTS_MAX + 2];
    int count = hn_constraints_all(c, n, &r, &behind, all);
    hn_mask_set(out, 0xffffffffu);
    for (int p = 0; p < count; p++) {
        if (!(all[p].b > 0.0f))
            continue; /* p: an upper bound on z */
        for (int q = 0; q < count; q++) {
            if (HN_PAIR_SKIPPED(all, p, q))
                continue; /* q: a lower bound (or b = 0, a constraint on omega alone) */
            float cx, cy, v = hn_constraint_pair(&all[p], &all[q], r, &cx, &cy);
            if (!(v > -1.0f)) {
                hn_mask_set(out, 0u);
                return;
            }
            if (v >= 1.0f)
                continue;
            unsigned int m[VX_MASK_WORDS];
            hn_mask_lookup(table, hn_atan2f(cy, cx), v, m);
            for (int w = 0; w < VX_MASK_WORDS; w++)
                out[w] &= m[w];
        }
    }
}

/* Whether hn_constraints_mask(c, n, r, behind) is empty for want of a ray that any one pair of the
 * bounds admits: the same pairs with the same arithmetic, without the table. Then the mask of c and
 * any further constraints is empty too (more constraints only take rays away), so a caller may
 * learn it before it works out the further constraints. */
VX_INLINE int hn_constraints_empty(const hn_constraint *c, int n, float r, float behind)
{
    hn_constraint all[HN_CONSTRAINTS_MAX + 2];
    int count = hn_constraints_all(c, n, &r, &behind, all);
    for (int p = 0; p < count; p++) {
        if (!(all[p].b > 0.0f))
            continue;
        for (int q = 0; q < count; q++) {
            if (HN_PAIR_SKIPPED(all, p, q))
                continue;
            float cx, cy;
            if (!(hn_constraint_pair(&all[p], &all[q], r, &cx, &cy) > -1.0f))
                return 1;
        }
    }
    return 0;
}

#endif
