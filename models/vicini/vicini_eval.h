/* `vicini`: the record and its evaluation (Vicini, Jakob and Kaplanyan 2021, "A Non-Exponential
 * Transmittance Model for Volumetric Scene Representations", as Brito et al. 2023 §5 compare it:
 * 11 bytes per voxel). Portable C: models/vicini/vicini.c uses these functions as the model's
 * opacity, transmit and shade, and the OpenCL backend compiles this same file as OpenCL C.
 *
 * Transmittance (Vicini §4-5). A voxel holds a density rho and a mix gamma between exponential and
 * linear transmittance: a ray crossing optical depth tau in it keeps
 *     f(tau, gamma) = gamma exp(-tau) + (1 - gamma) max(1 - tau / 2, 0),
 * and through several voxels the heterogeneous model carries the transmittance T reached so far:
 * it is turned into the equivalent optical depth of the current voxel's mix, the voxel's depth is
 * added, and the result is turned back (never brightening):
 *     T' = min(T, f(f^-1(T, gamma) + tau, gamma)).
 * The optical depth along direction w over a voxel is tau = rho sigma(w) l(w): sigma(w) =
 * sqrt(w^T S w) is the SGGX projected area (Heitz et al. 2015: a microflake volume's extinction
 * depends on the direction, so a voxel holding a plate is opaque face-on and clear edge-on), and
 * l(w) = 1 / (|wx| + |wy| + |wz|) the voxel's mean chord along w in voxel units (its volume over
 * its projected area). The mean chord rather than the ray's own segment: the paper's renderer
 * caches one answer per voxel for the direction voxel -> camera, and the same number must serve
 * every ray and every shadow ray (opacity_by_direction).
 *
 * Shading: single scattering by the SGGX microflake phase functions (Heitz et al. 2015 §4), lit by
 * each light with its shadows already applied. Per unit of transmittance the voxel removes
 * (the compositing weight), the radiance toward w_o from light l is
 *     E_l sigma(w_l) / sigma(w_o) [albedo f_diffuse(w_l -> w_o) + k_s f_specular(w_l -> w_o)],
 * which for a plate's distribution is exactly Lambert's E albedo cos(theta_l) / pi. The diffuse
 * phase function is an integral over the visible normals, evaluated with a fixed 4x4 stratified
 * set of visible-normal samples (deterministic, so both backends and every run agree); the
 * specular one is closed form, D(h) / (4 sigma(w_l)). The distribution is symmetric: a light
 * behind a surface sees the mirror images of its normals and lights them (Brito et al. Figure 10,
 * bottom) -- kept, it is what the comparison shows.
 *
 * Quantisation (11 bytes): S as Heitz et al.'s six bytes (sqrt of the diagonal over its largest
 * value, and the three correlations), density on a log scale, gamma in 7 bits with a specular bit,
 * colour in one byte per channel with a square-law code (more steps in the darks). */
#ifndef VX_VICINI_EVAL_H
#define VX_VICINI_EVAL_H

#include "model.h"
#include "shading.h"
#include "simd.h"

typedef struct {
    unsigned char sigma[3];  /* sqrt(S_kk) / max_k sqrt(S_kk): code / 255 */
    unsigned char corr[3];   /* S_xy, S_xz, S_yz over sqrt of their diagonals: (code - 127) / 127, 0..254 */
    unsigned char density;   /* 0: none; 1..255: VICINI_DENSITY_MIN .. VICINI_DENSITY_MAX, log spaced */
    unsigned char mix;       /* bits 0-6: gamma = code / 127, 0 linear (surface-like), 1 exponential
                                (volume-like); bit 7: the surfaces are specular (VICINI_SPECULAR_F0) */
    unsigned char color[3];  /* (code / 255)^2 */
} vicini_record;

#define VICINI_DENSITY_MIN 0.00390625f /* 2^-8 per voxel length */
#define VICINI_DENSITY_LOG2_RANGE 16.0f /* up to 2^8 */
#define VICINI_CORR_MAX_CODE 254

/* The density a code stands for (0 for code 0). */
VX_INLINE float vicini_decode_density(unsigned int code)
{
    if (code == 0u)
        return 0.0f;
    return VICINI_DENSITY_MIN * exp2f((float)(code - 1u) * (VICINI_DENSITY_LOG2_RANGE / 254.0f));
}

#define VICINI_GAMMA_MAX_CODE 127u
#define VICINI_SPECULAR_BIT 128u

VX_INLINE float vicini_decode_gamma(unsigned int mix)
{
    return (float)(mix & VICINI_GAMMA_MAX_CODE) / (float)VICINI_GAMMA_MAX_CODE;
}

/* The SGGX matrix (row-major 3x3, symmetric), with a small floor on the diagonal so that a
 * quantised record stays positive definite. */
VX_INLINE void vicini_decode_sggx(VX_GLOBAL const vicini_record *r, float S[9])
{
    float s[3], c[3];
    for (int k = 0; k < 3; k++) {
        s[k] = (float)r->sigma[k] / 255.0f;
        c[k] = ((float)r->corr[k] - 127.0f) / 127.0f;
    }
    S[0] = s[0] * s[0] + 1e-4f;
    S[4] = s[1] * s[1] + 1e-4f;
    S[8] = s[2] * s[2] + 1e-4f;
    S[1] = S[3] = c[0] * s[0] * s[1];
    S[2] = S[6] = c[1] * s[0] * s[2];
    S[5] = S[7] = c[2] * s[1] * s[2];
}

VX_INLINE float vicini_quadratic(const float S[9], vec3 w)
{
    return w.x * (S[0] * w.x + S[1] * w.y + S[2] * w.z) + w.y * (S[3] * w.x + S[4] * w.y + S[5] * w.z) +
           w.z * (S[6] * w.x + S[7] * w.y + S[8] * w.z);
}

/* SGGX projected area toward w (unit). */
VX_INLINE float vicini_sigma(const float S[9], vec3 w)
{
    return sqrtf(vx_fmaxf(vicini_quadratic(S, w), 1e-8f));
}

/* The voxel's mean chord along w, in voxel lengths. */
VX_INLINE float vicini_mean_chord(vec3 w)
{
    return 1.0f / vx_fmaxf(fabsf(w.x) + fabsf(w.y) + fabsf(w.z), 1.0f);
}

/* vicini_f with expf(-tau) given as e (the Newton step below needs it twice). */
VX_INLINE float vicini_f_with_exp(float e, float tau, float gamma)
{
    return gamma * e + (1.0f - gamma) * vx_fmaxf(1.0f - 0.5f * tau, 0.0f);
}

/* Vicini's transmittance after optical depth tau, for the mix gamma. A purely linear mix (gamma 0:
 * most of bunny's voxels at 256^3, 72 % of the calls) takes no expf: for tau >= 0 the exponential
 * is finite and non-negative, so gamma * e is a zero of gamma's sign whatever e is, the same bits
 * as with the call (a NaN or negative tau still calls it, where e could be NaN or infinite). */
VX_INLINE float vicini_f(float tau, float gamma)
{
    float e = gamma == 0.0f && tau >= 0.0f ? 0.0f : expf(-tau);
    return vicini_f_with_exp(e, tau, gamma);
}

/* The optical depth at which f(., gamma) falls to y: f^-1(y, gamma). Beyond tau = 2 only the
 * exponential part is left, so there the inverse is closed form; below, f is convex and
 * decreasing, and Newton's method started at 0 climbs to the root from the left without ever
 * passing it. y = 0 with an exponential part maps to a depth whose transmittance is 0 in float. */
VX_INLINE float vicini_f_inv(float y, float gamma)
{
    y = vx_fminf(vx_fmaxf(y, 0.0f), 1.0f);
    if (y >= 1.0f)
        return 0.0f;
    if (gamma <= 0.0f)
        return 2.0f * (1.0f - y);
    if (y <= gamma * 0.13533528f) /* f(2) = gamma e^-2: the root lies in the exponential tail */
        return y > 0.0f ? vx_fminf(-logf(y / gamma), 104.0f) : 104.0f;
    /* e = expf(-tau), one call per step for both the slope and the value (C's expf may set errno,
     * so the compiler does not merge two calls itself), and none at the start, where it is 1: the
     * same numbers as calling it there, one expf fewer per inversion (about a quarter of them). */
    float tau = 0.0f, e = 1.0f;
    for (int i = 0; i < 8; i++) {
        float slope = gamma * e + 0.5f * (1.0f - gamma); /* -df/dtau below tau = 2 */
        float step = (vicini_f_with_exp(e, tau, gamma) - y) / slope;
        if (!(step > 1e-7f))
            break;
        tau = vx_fminf(tau + step, 2.0f);
        e = expf(-tau);
    }
    return tau;
}

#ifndef __OPENCL_VERSION__
#include <stdint.h>
#include <string.h>

/* vicini_f_inv remembered by its arguments' bits, per thread (the C build; OpenCL C has no such
 * storage and computes it every time). Why: the transmit step inverts the voxel's own opacity at
 * every visit, and a voxel's opacity is the same number at each of them (the shading cache's
 * answer toward the camera, or the shadow memo's toward a light), so most of the Newton iterations
 * (expf each) were repeats: bunny 256^3 visits its voxels about six times each. The step's
 * inversion of the transmittance a ray brings is remembered too: a pixel's rays cross the same
 * voxels in turn and bring the same numbers. A pure function of
 * the bits: a remembered answer is the computed one, images unchanged. Direct-mapped; an entry
 * holds key + 1 (0: empty), so the key of all-ones bits (two NaNs) is never stored. */
#define VICINI_INV_MEMO_BITS 10
VX_INLINE float vicini_f_inv_remembered(float y, float gamma)
{
    static _Thread_local uint64_t key_plus_1[1u << VICINI_INV_MEMO_BITS];
    static _Thread_local float value[1u << VICINI_INV_MEMO_BITS];
    /* The inversions that take no Newton step are answered as vicini_f_inv answers them, without
     * the table: an unattenuated T (every ray's and shadow ray's first step brings 1) and a purely
     * linear mix. They cost less than a lookup and would only crowd out the entries that do. */
    if (y >= 1.0f || gamma <= 0.0f)
        return vicini_f_inv(y, gamma);
    uint32_t yb, gb;
    memcpy(&yb, &y, sizeof yb);
    memcpy(&gb, &gamma, sizeof gb);
    uint64_t key = (uint64_t)yb << 32 | gb;
    size_t slot = (size_t)((key * UINT64_C(0x9E3779B97F4A7C15)) >> (64 - VICINI_INV_MEMO_BITS));
    if (key_plus_1[slot] == key + 1u)
        return value[slot];
    float tau = vicini_f_inv(y, gamma);
    key_plus_1[slot] = key + 1u;
    value[slot] = tau;
    return tau;
}
#else
#define vicini_f_inv_remembered vicini_f_inv
#endif

/* The heterogeneous model's step: transmittance T, then a voxel of optical depth tau. */
VX_INLINE float vicini_step(float T, float tau, float gamma)
{
    return vx_fminf(T, vicini_f(vicini_f_inv_remembered(T, gamma) + tau, gamma));
}

/* The voxel's opacity toward q->ray_dir for a ray arriving unattenuated: 1 - f(tau, gamma). */
VX_INLINE float vicini_eval_opacity(VX_GLOBAL const void *record, const vx_query *q)
{
    VX_GLOBAL const vicini_record *r = (VX_GLOBAL const vicini_record *)record;
    float rho = vicini_decode_density(r->density);
    if (!(rho > 0.0f))
        return 0.0f;
    float S[9];
    vicini_decode_sggx(r, S);
    float tau = rho * vicini_sigma(S, q->ray_dir) * vicini_mean_chord(q->ray_dir);
    return 1.0f - vicini_f(tau, vicini_decode_gamma(r->mix));
}

/* The transmittance behind the voxel: its own depth (recovered from its opacity) added to the
 * depth T amounts to under its mix. */
VX_INLINE float vicini_eval_transmit(VX_GLOBAL const void *record, float opacity, float T)
{
    VX_GLOBAL const vicini_record *r = (VX_GLOBAL const vicini_record *)record;
    float gamma = vicini_decode_gamma(r->mix);
    return vicini_step(T, vicini_f_inv_remembered(1.0f - opacity, gamma), gamma);
}

/* The visible normals of the distribution S seen from wi (Heitz et al. 2015, Appendix: the ellipsoid
 * projected into the frame (wk, wj, wi)): the part that does not depend on the sample, computed once
 * for all of vicini_phase_diffuse's samples (it was computed again for each of the 16: the same
 * expressions on the same numbers, so the same bits). */
typedef struct {
    vec3 wk, wj, wi;
    vec3 Mk, Mj, Mi;
} vicini_visible_frame;

VX_INLINE void vicini_visible_frame_of(const float S[9], vec3 wi, vicini_visible_frame *fr)
{
    vec3 wk, wj;
    v3_basis(wi, &wk, &wj);
    vec3 Sk = v3(S[0] * wk.x + S[1] * wk.y + S[2] * wk.z, S[3] * wk.x + S[4] * wk.y + S[5] * wk.z,
                 S[6] * wk.x + S[7] * wk.y + S[8] * wk.z);
    vec3 Sj = v3(S[0] * wj.x + S[1] * wj.y + S[2] * wj.z, S[3] * wj.x + S[4] * wj.y + S[5] * wj.z,
                 S[6] * wj.x + S[7] * wj.y + S[8] * wj.z);
    vec3 Si = v3(S[0] * wi.x + S[1] * wi.y + S[2] * wi.z, S[3] * wi.x + S[4] * wi.y + S[5] * wi.z,
                 S[6] * wi.x + S[7] * wi.y + S[8] * wi.z);
    float S_kk = v3_dot(wk, Sk), S_jj = v3_dot(wj, Sj), S_ii = v3_dot(wi, Si);
    float S_kj = v3_dot(wk, Sj), S_ki = v3_dot(wk, Si), S_ji = v3_dot(wj, Si);
    float det = S_kk * S_jj * S_ii - S_kj * S_kj * S_ii - S_ki * S_ki * S_jj - S_ji * S_ji * S_kk +
                2.0f * S_kj * S_ki * S_ji;
    float sqrt_det = sqrtf(fabsf(det));
    float inv_sqrt_ii = 1.0f / sqrtf(vx_fmaxf(S_ii, 1e-12f));
    float tmp = sqrtf(vx_fmaxf(S_jj * S_ii - S_ji * S_ji, 1e-12f));
    fr->wk = wk;
    fr->wj = wj;
    fr->wi = wi;
    fr->Mk = v3(sqrt_det / tmp, 0.0f, 0.0f);
    fr->Mj = v3(-inv_sqrt_ii * (S_ki * S_ji - S_kj * S_ii) / tmp, inv_sqrt_ii * tmp, 0.0f);
    fr->Mi = v3(inv_sqrt_ii * S_ki, inv_sqrt_ii * S_ji, inv_sqrt_ii * S_ii);
}

/* The point of the unit disk (u, v) and its height w above it for the uniform pair (u1, u2). */
VX_INLINE void vicini_disk_sample(float u1, float u2, float *u, float *v, float *w)
{
    float rad = sqrtf(u1), phi = 2.0f * VX_PI * u2;
    *u = rad * cosf(phi);
    *v = rad * sinf(phi);
    *w = sqrtf(vx_fmaxf(1.0f - *u * *u - *v * *v, 0.0f));
}

/* A visible normal of the frame's distribution for the uniform pair (u1, u2). */
VX_INLINE vec3 vicini_visible_normal(const vicini_visible_frame *fr, float u1, float u2)
{
    float u, v, w;
    vicini_disk_sample(u1, u2, &u, &v, &w);
    vec3 m = v3_normalize(v3_add(v3_add(v3_scale(fr->Mk, u), v3_scale(fr->Mj, v)), v3_scale(fr->Mi, w)));
    return v3_add(v3_add(v3_scale(fr->wk, m.x), v3_scale(fr->wj, m.y)), v3_scale(fr->wi, m.z));
}

#define VICINI_DIFFUSE_STRATA 4 /* 4 x 4 visible-normal samples per light */
#define VICINI_DIFFUSE_SAMPLES (VICINI_DIFFUSE_STRATA * VICINI_DIFFUSE_STRATA)

/* The uniform pair of diffuse sample i (a = i / 4, b = i % 4): the centres of the 4 x 4 strata. */
VX_INLINE float vicini_diffuse_u1(int i) { return ((float)(i / VICINI_DIFFUSE_STRATA) + 0.5f) / VICINI_DIFFUSE_STRATA; }
VX_INLINE float vicini_diffuse_u2(int i) { return ((float)(i % VICINI_DIFFUSE_STRATA) + 0.5f) / VICINI_DIFFUSE_STRATA; }

/* The SGGX diffuse phase function (1/pi) E_{m ~ D_wi}[max(0, wo . m)], with wi toward the light.
 * The definition, and the OpenCL build's code; the C build runs vicini_phase_diffuse_sse
 * (vicini_phase_sse.h), the same bits. */
VX_INLINE float vicini_phase_diffuse_scalar(const float S[9], vec3 wi, vec3 wo)
{
    float sum = 0.0f;
    vicini_visible_frame fr;
    vicini_visible_frame_of(S, wi, &fr);
    for (int i = 0; i < VICINI_DIFFUSE_SAMPLES; i++) {
        vec3 m = vicini_visible_normal(&fr, vicini_diffuse_u1(i), vicini_diffuse_u2(i));
        sum += vx_fmaxf(v3_dot(wo, m), 0.0f);
    }
    return sum / (VX_PI * (float)VICINI_DIFFUSE_SAMPLES);
}

#ifdef VX_SSE
#include "vicini_phase_sse.h"
#endif

VX_INLINE float vicini_phase_diffuse(const float S[9], vec3 wi, vec3 wo)
{
#ifdef VX_SSE
    return vicini_phase_diffuse_sse(S, wi, wo);
#else
    return vicini_phase_diffuse_scalar(S, wi, wo);
#endif
}

/* The SGGX normal distribution D(m) = 1 / (pi sqrt(det S) (m^T S^-1 m)^2). */
VX_INLINE float vicini_ndf(const float S[9], vec3 m)
{
    float c00 = S[4] * S[8] - S[5] * S[7], c01 = S[2] * S[7] - S[1] * S[8], c02 = S[1] * S[5] - S[2] * S[4];
    float c11 = S[0] * S[8] - S[2] * S[6], c12 = S[2] * S[3] - S[0] * S[5], c22 = S[0] * S[4] - S[1] * S[3];
    float det = S[0] * c00 + S[1] * (S[5] * S[6] - S[3] * S[8]) + S[2] * (S[3] * S[7] - S[4] * S[6]);
    if (!(det > 0.0f))
        return 0.0f;
    /* m^T adj(S) m / det = m^T S^-1 m (S symmetric, so adj(S) is too). */
    float q = (m.x * m.x * c00 + m.y * m.y * c11 + m.z * m.z * c22 + 2.0f * (m.x * m.y * c01 + m.x * m.z * c02 + m.y * m.z * c12)) / det;
    return 1.0f / (VX_PI * sqrtf(det) * q * q);
}

/* The specular reflectance under `specular` of a voxel whose specular bit is set: 11 bytes leave no
 * room for a material's own, so it is the dielectric 0.04 every shipped specular material uses
 * (README: what vicini cannot represent). The lobe's width is the SGGX distribution's, into which
 * the bake folds the materials' roughness. */
#define VICINI_SPECULAR_F0 0.04f

/* Radiance toward q->to_viewer, per unit of transmittance removed (see the top of this file). */
VX_INLINE void vicini_eval_shade(VX_GLOBAL const void *record, const vx_query *q, vx_answer *a)
{
    VX_GLOBAL const vicini_record *r = (VX_GLOBAL const vicini_record *)record;
    float S[9];
    vicini_decode_sggx(r, S);
    vec3 albedo = v3((float)r->color[0] / 255.0f, (float)r->color[1] / 255.0f, (float)r->color[2] / 255.0f);
    albedo = v3_mul(albedo, albedo);
    vec3 wo = q->to_viewer;
    float sigma_o = vicini_sigma(S, wo);
    vec3 sum = v3(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < q->light_count; i++) {
        vec3 wi = q->to_light[i];
        float ratio = vicini_sigma(S, wi) / sigma_o;
        vec3 f = v3_scale(albedo, ratio * vicini_phase_diffuse(S, wi, wo));
        if ((q->effects & VX_EFFECT_SPECULAR) && (r->mix & VICINI_SPECULAR_BIT)) {
            vec3 h = v3_normalize_or(v3_add(wi, wo), wo);
            float spec = VICINI_SPECULAR_F0 * vicini_ndf(S, h) / (4.0f * sigma_o);
            f = v3_add(f, v3(spec, spec, spec));
        }
        sum = v3_add(sum, v3_mul(f, q->irradiance[i]));
    }
    a->radiance = sum;
}

#endif
