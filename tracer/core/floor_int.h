/* Cheap exact forms of two double operations on the cone marcher's hot path.
 *
 * floor() to an int for the portable code's cell lookups (cone marcher, cone elements): the
 * truncation, one less for a negative non-integer. Exactly (int)floor(u) for |u| < 2^31 (callers
 * keep their coordinates far inside that).
 * Why: PoCL's floor(double) is a dozen instructions (truncate, compare, fix up the sign and the
 * large values) where gcc emits one roundsd, and the marcher takes a floor per axis per element:
 * 10 % of the OpenCL cone kernel went there. This form costs about the same as roundsd in C. */
#ifndef VX_FLOOR_INT_H
#define VX_FLOOR_INT_H

#include "vec.h"

VX_INLINE int vx_floor_int(double u)
{
    int i = (int)u;
    return (double)i > u ? i - 1 : i;
}

/* 1 / 2^k for 0 <= k <= 1022, exactly 1.0 / (double)(1u << k) without the division (about 15
 * cycles of latency, once per level tried per element): the double's exponent field built. */
#ifdef __OPENCL_VERSION__
VX_INLINE double vx_inv_pow2(int k)
{
    return as_double((ulong)(1023 - k) << 52);
}
#else
#include <stdint.h>
#include <string.h>
static inline double vx_inv_pow2(int k)
{
    uint64_t bits = (uint64_t)(1023 - k) << 52;
    double d;
    memcpy(&d, &bits, sizeof d);
    return d;
}
#endif

#endif
