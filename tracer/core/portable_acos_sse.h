/* vx_acosf (portable_acos.h) four lanes at a time, for the C build's SSE paths (SSE4.1: the
 * project's x86-64-v2 target). Every lane evaluates vx_acosf's expressions in its order: SSE's
 * single-precision add, subtract, multiply and square root round exactly as the scalar operations
 * do (no FMA on this target, no contraction in ISO C mode), and both of vx_acosf's branches are
 * computed and one is chosen per lane, so each lane has vx_acosf's bits (tests/unit_vmesh_view.c
 * compares them over [-1, 1]). */
#ifndef VX_PORTABLE_ACOS_SSE_H
#define VX_PORTABLE_ACOS_SSE_H

#include <smmintrin.h>

static inline __m128 vx_acosf4(__m128 x)
{
    const __m128 sign = _mm_set1_ps(-0.0f);
    __m128 neg = _mm_cmplt_ps(x, _mm_setzero_ps()); /* x < 0.0f */
    __m128 a = _mm_blendv_ps(x, _mm_xor_ps(x, sign), neg);
    __m128 far = _mm_cmpgt_ps(a, _mm_set1_ps(0.5f));
    __m128 z = _mm_blendv_ps(_mm_mul_ps(a, a), _mm_mul_ps(_mm_set1_ps(0.5f), _mm_sub_ps(_mm_set1_ps(1.0f), a)), far);
    __m128 s = _mm_blendv_ps(a, _mm_sqrt_ps(z), far);
    __m128 p = _mm_add_ps(_mm_mul_ps(_mm_set1_ps(4.2163199048e-2f), z), _mm_set1_ps(2.4181311049e-2f));
    p = _mm_add_ps(_mm_mul_ps(p, z), _mm_set1_ps(4.5470025998e-2f));
    p = _mm_add_ps(_mm_mul_ps(p, z), _mm_set1_ps(7.4953002686e-2f));
    p = _mm_add_ps(_mm_mul_ps(p, z), _mm_set1_ps(1.6666752422e-1f));
    p = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(p, z), s), s);
    __m128 two_p = _mm_mul_ps(_mm_set1_ps(2.0f), p);
    __m128 beyond = _mm_blendv_ps(two_p, _mm_sub_ps(_mm_set1_ps(3.14159265358979f), two_p), neg);
    __m128 within = _mm_sub_ps(_mm_set1_ps(1.57079632679490f), _mm_blendv_ps(p, _mm_xor_ps(p, sign), neg));
    return _mm_blendv_ps(within, beyond, far);
}

#endif
