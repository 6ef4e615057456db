/* vicini_phase_diffuse (vicini_eval.h) with four of its 16 visible-normal samples per SSE vector,
 * for the C build (SSE4.1: the project's x86-64-v2 target). Why: the shading was the largest part
 * of a vicini frame's own work (14 % of its profile, more than transmit): per sample and light a
 * normalisation (square root, division) and two frame changes, each independent of the others.
 *
 * The same bits as vicini_phase_diffuse_scalar (tests/unit_vicini.c compares them): each lane
 * evaluates the scalar expressions in their order (SSE's single-precision add, multiply, divide
 * and square root round as the scalar operations do on this target, no FMA, no contraction), the
 * zero-length fallback is chosen per lane, maxps(d, 0) is vx_fmaxf(d, 0) for every d (NaN and -0
 * included), and the samples are summed in the scalar loop's order. The samples' points on the
 * disk depend on their index only: computed once per thread by vicini_disk_sample itself. */
#ifndef VX_VICINI_PHASE_SSE_H
#define VX_VICINI_PHASE_SSE_H

#include <smmintrin.h>

#include "vec_sse.h"

/* vicini_disk_sample of the 16 strata, [0]: u, [1]: v, [2]: w. */
static inline const float (*vicini_disk_samples(void))[VICINI_DIFFUSE_SAMPLES]
{
    static _Thread_local float table[3][VICINI_DIFFUSE_SAMPLES];
    static _Thread_local int ready;
    if (!ready) {
        for (int i = 0; i < VICINI_DIFFUSE_SAMPLES; i++)
            vicini_disk_sample(vicini_diffuse_u1(i), vicini_diffuse_u2(i), &table[0][i], &table[1][i], &table[2][i]);
        ready = 1;
    }
    return (const float (*)[VICINI_DIFFUSE_SAMPLES])table;
}

static inline float vicini_phase_diffuse_sse(const float S[9], vec3 wi, vec3 wo)
{
    const float(*disk)[VICINI_DIFFUSE_SAMPLES] = vicini_disk_samples();
    vicini_visible_frame fr;
    vicini_visible_frame_of(S, wi, &fr);
    float cosines[VICINI_DIFFUSE_SAMPLES];
    for (int i = 0; i < VICINI_DIFFUSE_SAMPLES; i += 4) {
        __m128 u = _mm_loadu_ps(&disk[0][i]), v = _mm_loadu_ps(&disk[1][i]), w = _mm_loadu_ps(&disk[2][i]);
        /* m = v3_normalize(Mk u + Mj v + Mi w), (0, 0, 1) where its length is not above 1e-30 */
        __m128 mx = vx_dot3_ps(fr.Mk.x, fr.Mj.x, fr.Mi.x, u, v, w);
        __m128 my = vx_dot3_ps(fr.Mk.y, fr.Mj.y, fr.Mi.y, u, v, w);
        __m128 mz = vx_dot3_ps(fr.Mk.z, fr.Mj.z, fr.Mi.z, u, v, w);
        __m128 len = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(mx, mx), _mm_mul_ps(my, my)), _mm_mul_ps(mz, mz)));
        __m128 long_enough = _mm_cmpgt_ps(len, _mm_set1_ps(1e-30f)), inv = _mm_div_ps(_mm_set1_ps(1.0f), len);
        mx = _mm_and_ps(long_enough, _mm_mul_ps(mx, inv));
        my = _mm_and_ps(long_enough, _mm_mul_ps(my, inv));
        mz = _mm_blendv_ps(_mm_set1_ps(1.0f), _mm_mul_ps(mz, inv), long_enough);
        /* the world's normal wk m.x + wj m.y + wi m.z, and wo . it */
        __m128 nx = vx_dot3_ps(fr.wk.x, fr.wj.x, fr.wi.x, mx, my, mz);
        __m128 ny = vx_dot3_ps(fr.wk.y, fr.wj.y, fr.wi.y, mx, my, mz);
        __m128 nz = vx_dot3_ps(fr.wk.z, fr.wj.z, fr.wi.z, mx, my, mz);
        __m128 d = vx_dot3_ps(wo.x, wo.y, wo.z, nx, ny, nz);
        _mm_storeu_ps(&cosines[i], _mm_max_ps(d, _mm_setzero_ps()));
    }
    float sum = 0.0f;
    for (int i = 0; i < VICINI_DIFFUSE_SAMPLES; i++)
        sum += cosines[i];
    return sum / (VX_PI * (float)VICINI_DIFFUSE_SAMPLES);
}

#endif
