/* Coverage masks of a cone element (Heitz & Neyret 2012 §5.4, 2011 report appendix B): which of
 * 128 Poisson-disk sample positions omega of the element's footprint (the unit disk, in the ray's
 * frame) see the mean surface plane within the element. Portable C: reads the precomputed table
 * (a plain array behind VX_GLOBAL, a buffer under OpenCL) and never builds it.
 *
 * The plane x.n + D = 0 in the element's frame (x, y across the footprint, z along the ray, origin
 * at the element's centre, D = signed distance of the centre above the plane) occupies the ray
 * through r omega when either end z = +-r (length = diameter) is below it:
 *   r omega.(nx, ny) - r |nz| + D <= 0  <=>  omega.(cos t, sin t) <= v = (r |nz| - D) / (r rho),
 * rho = sqrt(nx^2 + ny^2), t = atan2(ny, nx). The table holds the mask for 256 x 256 (t, v). */
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

/* Half-space mask: the element (radius r) against the plane with normal (nx, ny, nz) in the ray's
 * frame (unit) and the centre's signed distance D above it. A plane facing the ray head-on
 * (rho = 0) covers all or nothing: no division. */
VX_INLINE void hn_plane_mask(VX_GLOBAL const unsigned int *table, float nx, float ny, float nz, float D, float r,
                             unsigned int *out)
{
    r = fmaxf(r, 0.0f);
    float rho = sqrtf(nx * nx + ny * ny);
    float num = r * fabsf(nz) - D;
    float den = r * rho;
    if (!(den > 1e-30f)) {
        hn_mask_set(out, num >= 0.0f ? 0xffffffffu : 0u);
        return;
    }
    hn_mask_lookup(table, hn_atan2f(ny, nx), num / den, out);
}

/* Slab mask for a two-sided sheet of half-thickness tau: the rays through the element that cross
 * |x.n + D| <= tau, i.e. v_lo < omega.(cos t, sin t) <= v_hi. */
VX_INLINE void hn_slab_mask(VX_GLOBAL const unsigned int *table, float nx, float ny, float nz, float D, float r,
                            float tau, unsigned int *out)
{
    r = fmaxf(r, 0.0f);
    tau = fmaxf(tau, 0.0f);
    float rho = sqrtf(nx * nx + ny * ny);
    float reach = r * fabsf(nz) + tau;
    float den = r * rho;
    if (!(den > 1e-30f)) {
        hn_mask_set(out, fabsf(D) <= reach ? 0xffffffffu : 0u);
        return;
    }
    float t = hn_atan2f(ny, nx);
    unsigned int lo[VX_MASK_WORDS];
    hn_mask_lookup(table, t, (reach - D) / den, out);
    hn_mask_lookup(table, t, (-reach - D) / den, lo);
    for (int w = 0; w < VX_MASK_WORDS; w++)
        out[w] &= ~lo[w];
}

#endif
