/* First lines of every OpenCL program voxlab builds (see tracer/backends/opencl/opencl_program.c): what makes the
 * portable C headers (vec.h, rng.h, shading.h, grid_core.h, the models' *_eval.h ...) compile as
 * OpenCL C unchanged. */
#ifndef VX_CL_PRELUDE_H
#define VX_CL_PRELUDE_H

/* The grid mapping and the DDA are in double (grid_traverse_core.h). */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
/* OpenCL C may fuse a * b + c into one fma by default; the C build (x86-64-v2, no FMA) never does.
 * Fused and unfused results differ in the last bit, and in the DDA a last-bit difference can pick
 * another cell, so contraction is off: both backends then evaluate the same expressions the same way. */
#pragma OPENCL FP_CONTRACT OFF

/* The C99 float functions the portable code calls, under their OpenCL C (overloaded) names. */
#define sqrtf sqrt
#define cbrtf cbrt
#define fabsf fabs
#define fminf fmin
#define fmaxf fmax
#define fdimf fdim
#define fmaf fma
#define fmodf fmod
#define remainderf remainder
#define floorf floor
#define ceilf ceil
#define roundf round
#define truncf trunc
#define rintf rint
#define copysignf copysign
#define nextafterf nextafter
#define ldexpf ldexp
#define frexpf frexp
#define logbf logb
#define hypotf hypot
#define expf exp
#define exp2f exp2
#define expm1f expm1
#define logf log
#define log2f log2
#define log10f log10
#define log1pf log1p
#define powf pow
#define sinf sin
#define cosf cos
#define tanf tan
#define asinf asin
#define acosf acos
#define atanf atan
#define atan2f atan2
#define sinhf sinh
#define coshf cosh
#define tanhf tanh
#define asinhf asinh
#define acoshf acosh
#define atanhf atanh
#define erff erf
#define erfcf erfc
#define lgammaf lgamma
#define tgammaf tgamma

/* Fixed-width integers: rng.h names uint64_t and uint32_t for OpenCL C (it is included here first
 * so that nothing defines them twice), the rest are named here. */
#include "rng.h"
typedef long int64_t;
typedef int int32_t;
typedef short int16_t;
typedef ushort uint16_t;
typedef char int8_t;
typedef uchar uint8_t;

/* vec.h makes VX_INLINE a plain C99 `inline` for OpenCL C, which promises an external definition
 * elsewhere that an OpenCL program never has; every header after vec.h gets `static inline`, so a
 * function the compiler decides not to inline is still defined in the program. */
#include "vec.h"
#undef VX_INLINE
#define VX_INLINE static inline

#endif
