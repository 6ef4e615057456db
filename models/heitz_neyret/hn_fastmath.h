/* atan2, log and erfc for float in portable C (also OpenCL C), for the functions Heitz–Neyret's
 * cone element calls on every element: the mask's angle (atan2), the visible depth (log), Smith's
 * Lambda and the height CDF (erfc).
 *
 * Why not the math library's: PoCL's (SLEEF's atan2, logf_u10, erfcf_u15) took 8 % of the OpenCL
 * cone kernel, three times what glibc's take in the C backend. These are a few multiplies, one
 * division and at most one exp, the same expressions in both backends (no fused multiply-add: the
 * C build has none and tracer/backends/opencl/cl/prelude.h turns contraction off), so C and OpenCL agree.
 * Accuracy (tests/unit_heitz_neyret.c checks it against double precision): atan2 and log within
 * a few 1e-7 (Cephes' atanf and logf, S. L. Moshier), erfc within about 1e-6 relative (Numerical
 * Recipes' erfcc, a Chebyshev fit to 1.2e-7 in exact arithmetic; the float exponent adds the
 * rest). Ternaries rather than fminf/fmaxf: in C those are libm calls. */
#ifndef VX_HN_FASTMATH_H
#define VX_HN_FASTMATH_H

#include "portable_hints.h"
#include "vec.h"

/* atan2(y, x) in [-pi, pi]; 0 for (0, 0) and NaN for NaN input (callers guard both). atan of the
 * ratio min/max of |x|, |y| (in [0, 1]: no overflow), reduced below tan(pi/8) by atan(a) =
 * pi/4 + atan((a - 1)/(a + 1)), a degree-9 odd polynomial there, then the octant restored. */
VX_INLINE float hn_atan2f(float y, float x)
{
    float ax = fabsf(x), ay = fabsf(y);
    int steep = ay > ax;
    float hi = steep ? ay : ax, lo = steep ? ax : ay;
    if (hi == 0.0f)
        return 0.0f;
    float a = lo / hi, base = 0.0f;
    if (a > 0.41421356237f) {
        base = 0.78539816340f;
        a = (a - 1.0f) / (a + 1.0f);
    }
    float z = a * a;
    float r = base + ((((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z -
                       3.33329491539e-1f) * z * a + a);
    if (steep)
        r = 1.57079632679f - r;
    if (x < 0.0f)
        r = 3.14159265359f - r;
    return y < 0.0f ? -r : r;
}

/* Natural log of a positive normal float x (others go to the library's log): x = m 2^e with m in
 * [sqrt(1/2), sqrt(2)), log(1 + f) for f = m - 1 as f - f^2/2 + f^3 P(f), e ln 2 added in two parts. */
VX_INLINE float hn_logf(float x)
{
    if (!(x >= 1.17549435e-38f && x <= 3.40282347e38f))
        return logf(x);
    uint32_t i = VX_FLOAT_BITS(x);
    int e = (int)(i >> 23) - 126;
    float f = VX_BITS_FLOAT((i & 0x007fffffu) | 0x3f000000u); /* in [1/2, 1) */
    if (f < 0.70710678118f) {
        e -= 1;
        f = f + f - 1.0f;
    } else {
        f = f - 1.0f;
    }
    float z = f * f;
    float y = ((((((((7.0376836292e-2f * f - 1.1514610310e-1f) * f + 1.1676998740e-1f) * f - 1.2420140846e-1f) * f +
                   1.4249322787e-1f) * f - 1.6668057665e-1f) * f + 2.0000714765e-1f) * f - 2.4999993993e-1f) * f +
               3.3333331174e-1f) * f * z;
    float fe = (float)e;
    y += -2.12194440e-4f * fe;
    y += -0.5f * z;
    return (f + y) + 0.693359375f * fe;
}

/* log(e^(x^2) erfc(x)) - log(t) for x >= 0, t = 1 / (1 + x/2): Numerical Recipes' Chebyshev fit. */
VX_INLINE float hn_erfc_exponent(float t)
{
    return -1.26551223f +
           t * (1.00002368f +
                t * (0.37409196f +
                     t * (0.09678418f +
                          t * (-0.18628806f +
                               t * (0.27886807f + t * (-1.13520398f + t * (1.48851587f + t * (-0.82215223f + t * 0.17087277f))))))));
}

/* erfc(x) for any x (NaN for NaN). */
VX_INLINE float hn_erfcf(float x)
{
    float z = fabsf(x);
    float t = 1.0f / (1.0f + 0.5f * z);
    float r = t * expf(-z * z + hn_erfc_exponent(t));
    return x >= 0.0f ? r : 2.0f - r;
}

/* e^(x^2) erfc(x) for x >= 0 (no overflow: the x^2 cancels before the exp). */
VX_INLINE float hn_erfcxf(float x)
{
    float t = 1.0f / (1.0f + 0.5f * x);
    return t * expf(hn_erfc_exponent(t));
}

#endif
