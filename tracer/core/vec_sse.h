/* vec.h's v3_dot four lanes at a time, for the C build's SSE paths (simd.h): v3_dot((a, b, c),
 * (x, y, z)) per lane, in v3_dot's order, (a x + b y) + c z. SSE's single-precision multiply and
 * add round as the scalar operations do on this target (no FMA, no contraction), so each lane has
 * the scalar expression's bits; the same shape serves v3_add(v3_add(v3_scale(p, x), v3_scale(q,
 * y)), v3_scale(r, z)) for one component (a = p's, b = q's, c = r's). */
#ifndef VX_VEC_SSE_H
#define VX_VEC_SSE_H

#include <smmintrin.h>

static inline __m128 vx_dot3_ps(float a, float b, float c, __m128 x, __m128 y, __m128 z)
{
    return _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(a), x), _mm_mul_ps(_mm_set1_ps(b), y)),
                      _mm_mul_ps(_mm_set1_ps(c), z));
}

#endif
