/* acos for float in portable C (also OpenCL C): Cephes' acosf (S. L. Moshier), a degree-5
 * polynomial for asin on |x| <= 1/2 and the half-angle identity beyond, within 2 ulp of the true
 * value over [-1, 1] (tests/unit_vmesh.c checks it against double acos).
 *
 * Why not the math library's: the render-time code calls acos on its hottest path (vmesh's
 * disk-disk overlap, two per call), where glibc's acosf and PoCL's (SLEEF's acosf_u10, about twice
 * as slow again) cost a large share of the render. This one is a few multiplies and at most one
 * sqrt, and, being the same expressions in both backends (no fused multiply-add: the C build has
 * none, tracer/backends/opencl/cl/prelude.h turns contraction off, and sqrt is correctly rounded in both), it gives
 * the C and OpenCL backends the same bits. */
#ifndef VX_PORTABLE_ACOS_H
#define VX_PORTABLE_ACOS_H

#include "vec.h"

/* acos(x) for x in [-1, 1] (callers clamp; outside, the result is meaningless but finite or NaN). */
VX_INLINE float vx_acosf(float x)
{
    const float pi = 3.14159265358979f, half_pi = 1.57079632679490f;
    float a = x < 0.0f ? -x : x;
    /* |x| > 1/2: acos(|x|) = 2 asin(sqrt((1 - |x|) / 2)), whose argument is at most 1/2 again. */
    int far = a > 0.5f;
    float z = far ? 0.5f * (1.0f - a) : a * a;
    float s = far ? sqrtf(z) : a;
    /* asin(s) for |s| <= 1/2, z = s^2. */
    float p = ((((4.2163199048e-2f * z + 2.4181311049e-2f) * z + 4.5470025998e-2f) * z + 7.4953002686e-2f) * z +
               1.6666752422e-1f) * z * s + s;
    if (far)
        return x < 0.0f ? pi - 2.0f * p : 2.0f * p;
    return half_pi - (x < 0.0f ? -p : p);
}

#endif
