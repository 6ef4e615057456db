/* The Heitz–Neyret per-voxel record (one per non-empty cell of every MIP level) and its decoding.
 * Portable C (OpenCL C too); the encoder is host-only.
 *
 * 28 bytes (the paper: 15-20 bytes with 8/16-bit channels; we add the material's specular
 * reflectance and roughness, which the paper keeps global):
 *   h         float   mean height of the cell's surface above the cell centre along the mean
 *                     normal (world units). 32 bits as the paper advises: it is the distance field.
 *   n[3]      snorm16 mean normal: the mean of the unit normals (length < 1 when they disagree);
 *                     for a two-sided cell (a thin sheet seen from both sides, whose normals cancel)
 *                     the unit axis of the sheet instead.
 *   var_h     half    sigma_h^2 / size^2 (relative to the cell's edge, so half floats suit any scale)
 *   var_n     half    slope variance sigma_n^2 per axis of the geometric surface (isotropic)
 *   area      half    surface area / size^2 (0: the grid marked the cell but no sample hit it);
 *                     negative when no sample hit a front face: the colour is unknown (a corner
 *                     clipped by the surface whose few hits all came from behind)
 *   a[3]      unorm8  mean albedo a
 *   as[3]     snorm8  a_s, the projection of the albedo on s(h) = 2 g(h) - 1, stored relative to
 *                     min(a, 1 - a) (the largest |a_s| that keeps a + a_s s(h) in [0, 1])
 *   alpha     unorm16 the material's Beckmann roughness (RMS slope) over [0, 2], the range a scene
 *                     may declare (scene.c); layout 1 kept it over [0, 1] in 8 bits, so a rougher
 *                     material was shaded as roughness 1 while the truth used its own
 *   f0_flags  bits 0-6 specular reflectance (unorm7), bit 7 two-sided
 *   psi       snorm8  where the surface ends within the plane: the in-plane signed distance psi
 *                     from the cell's centre to the boundary of its surface patch, over size / 2
 *                     (-size/2: the patch spans the cell; +size/2: it only touches a corner). The
 *                     cone element interpolates psi densely (empty cells count +size/2 where the
 *                     plane runs through them) so that a plane stops where its surface stops
 *                     instead of reaching past the occupied cells (hn_eval.h, hn_blend_edge).
 *   spare[2]  zero (the struct's padding, named so that every byte is defined)
 * Variances are stored (not deviations): they are what interpolates and combines linearly. */
#ifndef VX_HN_RECORD_H
#define VX_HN_RECORD_H

#include "hn_math.h"
#include "model.h"

#define HN_TWO_SIDED 0x80u
#define HN_ALPHA_MAX 2.0f /* the record's largest roughness: the scene's (scene.c's material roughness) */

typedef struct {
    float h;
    short n[3];
    unsigned short var_h, var_n, area;
    unsigned char a[3];
    signed char as[3];
    unsigned short alpha; /* offset 22: aligned */
    unsigned char f0_flags;
    signed char psi;
    unsigned char spare[2];
} hn_record;

/* A record decoded to floats. */
typedef struct {
    float h;          /* world units */
    vec3 n;           /* as stored (see above) */
    float var_h;      /* world units^2 */
    float var_n;
    float area;       /* world units^2 */
    int has_color;    /* some sample hit a front face (else a, as, f0, var_brdf mean nothing) */
    vec3 a, as;
    float var_brdf;   /* alpha^2 / 2 */
    float f0;
    int two_sided;
    float psi;        /* world units (see psi above) */
} hn_data;

/* The geometry of a record (h, n, var_h, var_n, area, has_color, two_sided; the colour fields are
 * left as they were). Why apart from hn_decode: the geometry blend reads up to 16 records per cone
 * element and needs none of the colour, whose eight divisions were most of the decode's cost. */
VX_HOT_INLINE void hn_decode_geometry(VX_GLOBAL const hn_record *r, float size, hn_data *d)
{
    d->h = r->h;
    d->n = v3((float)r->n[0] / 32767.0f, (float)r->n[1] / 32767.0f, (float)r->n[2] / 32767.0f);
    d->var_h = hn_half_to_float(r->var_h) * size * size;
    d->var_n = hn_half_to_float(r->var_n);
    float area = hn_half_to_float(r->area);
    d->area = fabsf(area) * size * size;
    d->has_color = area > 0.0f;
    d->two_sided = (r->f0_flags & HN_TWO_SIDED) != 0u;
    d->psi = (float)r->psi / 127.0f * 0.5f * size;
}

VX_INLINE void hn_decode(VX_GLOBAL const hn_record *r, float size, hn_data *d)
{
    hn_decode_geometry(r, size, d);
    d->a = v3((float)r->a[0] / 255.0f, (float)r->a[1] / 255.0f, (float)r->a[2] / 255.0f);
    /* a_s relative to its bound min(a, 1 - a): full 8-bit resolution whatever the mean colour. */
    float b0 = vx_fminf(d->a.x, 1.0f - d->a.x), b1 = vx_fminf(d->a.y, 1.0f - d->a.y), b2 = vx_fminf(d->a.z, 1.0f - d->a.z);
    d->as = v3((float)r->as[0] / 127.0f * b0, (float)r->as[1] / 127.0f * b1, (float)r->as[2] / 127.0f * b2);
    float alpha = (float)r->alpha * (HN_ALPHA_MAX / 65535.0f);
    d->var_brdf = 0.5f * alpha * alpha;
    d->f0 = (float)(r->f0_flags & 0x7fu) / 127.0f;
}

#ifndef __OPENCL_VERSION__
#include <math.h>

/* float -> IEEE half, round to nearest, saturating at 65504, flushing below 2^-24. */
static inline unsigned short hn_float_to_half(float f)
{
    if (!(f == f))
        return 0;
    unsigned short sign = f < 0.0f ? 0x8000u : 0u;
    float a = fabsf(f);
    if (a >= 65504.0f)
        return (unsigned short)(sign | 0x7bffu);
    if (a < ldexpf(1.0f, -14)) /* subnormal: units of 2^-24 */
        return (unsigned short)(sign | (unsigned short)lrintf(ldexpf(a, 24)));
    int e;
    float m = frexpf(a, &e); /* a = m 2^e, m in [0.5, 1) */
    long mant = lrintf(ldexpf(m, 11)); /* 1024..2048 */
    if (mant == 2048) {
        mant = 1024;
        e++;
    }
    int be = e + 14; /* biased exponent of 1.x * 2^(e-1) */
    if (be >= 31)
        return (unsigned short)(sign | 0x7bffu);
    return (unsigned short)(sign | (unsigned short)(be << 10) | (unsigned short)(mant - 1024));
}

static inline unsigned char hn_unorm8(float x)
{
    x = vx_fminf(vx_fmaxf(x, 0.0f), 1.0f); /* NaN -> 0 */
    return (unsigned char)lrintf(x * 255.0f);
}

static inline signed char hn_snorm8(float x)
{
    x = vx_fminf(vx_fmaxf(x, -1.0f), 1.0f);
    return (signed char)lrintf(x * 127.0f);
}

static inline short hn_snorm16(float x)
{
    x = vx_fminf(vx_fmaxf(x, -1.0f), 1.0f);
    return (short)lrintf(x * 32767.0f);
}

/* Encodes d for a cell of edge `size` (d->a in [0, 1]; a_s is clamped to its bound). */
static inline void hn_encode(const hn_data *d, float size, hn_record *r)
{
    float s2 = size * size;
    r->h = d->h;
    r->n[0] = hn_snorm16(d->n.x);
    r->n[1] = hn_snorm16(d->n.y);
    r->n[2] = hn_snorm16(d->n.z);
    r->var_h = hn_float_to_half(vx_fmaxf(d->var_h, 0.0f) / s2);
    r->var_n = hn_float_to_half(vx_fmaxf(d->var_n, 0.0f));
    r->area = hn_float_to_half(vx_fmaxf(d->area, 0.0f) / s2 * (d->has_color ? 1.0f : -1.0f));
    float a[3] = {d->a.x, d->a.y, d->a.z}, as[3] = {d->as.x, d->as.y, d->as.z};
    for (int c = 0; c < 3; c++) {
        r->a[c] = hn_unorm8(a[c]);
        float aq = (float)r->a[c] / 255.0f, bound = vx_fminf(aq, 1.0f - aq);
        r->as[c] = bound > 0.0f ? hn_snorm8(as[c] / bound) : 0;
    }
    float alpha = sqrtf(2.0f * vx_fmaxf(d->var_brdf, 0.0f)) / HN_ALPHA_MAX; /* var_brdf NaN -> 0 */
    r->alpha = (unsigned short)lrintf(vx_fminf(alpha, 1.0f) * 65535.0f);
    unsigned f0 = (unsigned)lrintf(vx_fminf(vx_fmaxf(d->f0, 0.0f), 1.0f) * 127.0f);
    r->f0_flags = (unsigned char)(f0 | (d->two_sided ? HN_TWO_SIDED : 0u));
    r->psi = hn_snorm8(d->psi / (0.5f * size));
    r->spare[0] = r->spare[1] = 0;
}
#endif

#endif
