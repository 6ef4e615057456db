/* A cone element's MIP level and the level whose emptiness proves it empty: the cone marcher's
 * (render_cone_core.h) and the maps of where cones ask about elements (render_cone.c's light cones'
 * ends, cone_camera_ends.c's camera cones' ends) share these, so that both make one decision.
 * Portable C (the OpenCL cone kernel includes it through render_cone_core.h). All three are
 * nondecreasing in their argument, which the maps rely on: cone_fast_log2's quadratic increases on
 * [1, 2) and steps up (by 0.01) where the exponent does. */
#ifndef VX_CONE_LEVELS_H
#define VX_CONE_LEVELS_H

#include "portable_hints.h"

/* log2 to within 5e-3 (the level only picks cells and a blend weight): the float's exponent plus a
 * quadratic in its mantissa. libm's log2f was 5 % of a render. */
VX_INLINE float cone_fast_log2(float x)
{
    if (!(x > 1e-30f))
        return -100.0f;
    uint32_t i = VX_FLOAT_BITS(x);
    float e = (float)((int)((i >> 23) & 255u) - 128); /* the quadratic below is log2(m) + 1 */
    float m = VX_BITS_FLOAT((i & 0x007fffffu) | 0x3f800000u); /* in [1, 2) */
    return e + (-0.34484843f * m + 2.02466578f) * m - 0.67487759f;
}

/* An element's fractional MIP level from its radius r (level_scale: 2 / the voxel size), within
 * [0, top]: log2(2 r / vs), by a multiply rather than a division. */
VX_INLINE float cone_element_level(float r, float level_scale, int top)
{
    float level = cone_fast_log2(r * level_scale);
    return level > 0.0f ? (level < (float)top ? level : (float)top) : 0.0f;
}

/* K_min: the finest level whose emptiness proves the stencil of an element of `level` empty
 * (floor(level) + 1, at most the top): the element's cell on it with its 26 neighbours. */
VX_INLINE int cone_proof_level(float level, int top) { return (int)level + 1 <= top ? (int)level + 1 : top; }

#endif
