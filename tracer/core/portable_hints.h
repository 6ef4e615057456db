/* Hints and bit casts for the code compiled both as C (gcc) and as OpenCL C (PoCL's clang/LLVM).
 *
 * VX_HOT_INLINE, VX_UNROLL: PoCL's LLVM left small per-element helpers as calls (arguments and
 * results through the stack) and fixed-count loops over axes or stencil cells rolled (their arrays
 * in memory), where gcc inlines and unrolls them by itself. So both are forced under OpenCL only;
 * in C the choice stays gcc's (which would also warn about the unknown pragma).
 * VX_FLOAT_BITS, VX_BITS_FLOAT: a float's bits and back, for the exponent tricks of the fast
 * log2/log (as_uint/as_float in OpenCL C; memcpy, which gcc turns into a register move, in C). */
#ifndef VX_PORTABLE_HINTS_H
#define VX_PORTABLE_HINTS_H

#include "vec.h"

#ifdef __OPENCL_VERSION__
#define VX_HOT_INLINE VX_INLINE __attribute__((always_inline))
#define VX_UNROLL _Pragma("unroll")
#define VX_FLOAT_BITS(x) as_uint(x)
#define VX_BITS_FLOAT(i) as_float(i)
#else
#include <stdint.h>
#include <string.h>
#define VX_HOT_INLINE VX_INLINE
#define VX_UNROLL
static inline uint32_t vx_float_bits(float x)
{
    uint32_t i;
    memcpy(&i, &x, sizeof i);
    return i;
}
static inline float vx_bits_float(uint32_t i)
{
    float x;
    memcpy(&x, &i, sizeof x);
    return x;
}
#define VX_FLOAT_BITS(x) vx_float_bits(x)
#define VX_BITS_FLOAT(i) vx_bits_float(i)
#endif

#endif
