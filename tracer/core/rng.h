/* Deterministic random numbers: a counter-based hash so that every pixel, voxel or sample can
 * seed its own stream from (seed, index) and results do not depend on the thread count. Portable C
 * (also compiles as OpenCL C). */
#ifndef VX_RNG_H
#define VX_RNG_H

#ifndef __OPENCL_VERSION__
#include <stdint.h>
#define VX_RNG_INLINE static inline
#else
#define VX_RNG_INLINE inline
typedef ulong uint64_t;
typedef uint uint32_t;
#endif

typedef struct {
    uint64_t state;
} rng;

/* SplitMix64 finaliser: a good 64-bit mixing function. */
VX_RNG_INLINE uint64_t rng_mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

VX_RNG_INLINE rng rng_seed(uint64_t seed, uint64_t stream)
{
    rng r;
    r.state = rng_mix64(seed * 0x9e3779b97f4a7c15ULL + rng_mix64(stream + 0x632be59bd9b4e019ULL));
    return r;
}

VX_RNG_INLINE uint32_t rng_u32(rng *r)
{
    r->state += 0x9e3779b97f4a7c15ULL;
    return (uint32_t)(rng_mix64(r->state) >> 32);
}

/* Uniform in [0, 1): 24 random bits, so the result is exactly representable and never 1. */
VX_RNG_INLINE float rng_float(rng *r) { return (float)(rng_u32(r) >> 8) * (1.0f / 16777216.0f); }

/* Uniform in [0, 1) with 53 bits, for generators that want doubles. */
VX_RNG_INLINE double rng_double(rng *r)
{
    uint64_t hi = rng_u32(r), lo = rng_u32(r);
    return (double)(((hi << 32) | lo) >> 11) * (1.0 / 9007199254740992.0);
}

#endif
