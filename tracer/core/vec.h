/* Small 3-vector maths. Plain C with no libc beyond <math.h>, so the per-voxel model code that
 * includes it also compiles as OpenCL C (where the VX_INLINE macro becomes plain `inline`). */
#ifndef VX_VEC_H
#define VX_VEC_H

#ifndef __OPENCL_VERSION__
#include <math.h>
#define VX_INLINE static inline
/* fminf, fmaxf, fmin, fmax as inline comparisons: GCC keeps the libm functions as calls (their
 * NaN rule is not one SSE instruction's), and the cone marcher and heitz-neyret call them per
 * element (3.5 % of a heitz-neyret frame in __fmin and __fmaxf alone, issue 15). Same results as
 * glibc's on x86-64 bit for bit, signed zeros included (tests/unit_vec.c compares them over the
 * special values): a NaN argument gives the other one, and a tie (+0 and -0) the second argument,
 * as glibc's (SSE's minss/maxss rule) do. */
static inline float vx_fminf(float a, float b) { return (a < b || b != b) ? a : b; }
static inline float vx_fmaxf(float a, float b) { return (a > b || b != b) ? a : b; }
static inline double vx_fmin(double a, double b) { return (a < b || b != b) ? a : b; }
static inline double vx_fmax(double a, double b) { return (a > b || b != b) ? a : b; }
#else
#define VX_INLINE inline
#define vx_fminf fmin
#define vx_fmaxf fmax
#define vx_fmin fmin
#define vx_fmax fmax
#endif

typedef struct {
    float x, y, z;
} vec3;

VX_INLINE vec3 v3(float x, float y, float z) { vec3 r = {x, y, z}; return r; }
VX_INLINE vec3 v3_add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
VX_INLINE vec3 v3_sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
VX_INLINE vec3 v3_mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
VX_INLINE vec3 v3_scale(vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
VX_INLINE vec3 v3_madd(vec3 a, vec3 b, float s) { return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
VX_INLINE float v3_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
VX_INLINE vec3 v3_cross(vec3 a, vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
VX_INLINE float v3_length(vec3 a) { return sqrtf(v3_dot(a, a)); }
VX_INLINE vec3 v3_min(vec3 a, vec3 b) { return v3(vx_fminf(a.x, b.x), vx_fminf(a.y, b.y), vx_fminf(a.z, b.z)); }
VX_INLINE vec3 v3_max(vec3 a, vec3 b) { return v3(vx_fmaxf(a.x, b.x), vx_fmaxf(a.y, b.y), vx_fmaxf(a.z, b.z)); }
VX_INLINE float v3_get(vec3 a, int axis) { return axis == 0 ? a.x : (axis == 1 ? a.y : a.z); }

/* Unit vector along a; a zero vector gives `fallback` instead of NaN. */
VX_INLINE vec3 v3_normalize_or(vec3 a, vec3 fallback)
{
    float len = v3_length(a);
    return len > 1e-30f ? v3_scale(a, 1.0f / len) : fallback;
}
VX_INLINE vec3 v3_normalize(vec3 a) { return v3_normalize_or(a, v3(0.0f, 0.0f, 1.0f)); }

/* An orthonormal basis (t, b) around a unit vector n (Duff et al. 2017, branchless). */
VX_INLINE void v3_basis(vec3 n, vec3 *t, vec3 *b)
{
    float sign = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (sign + n.z);
    float c = n.x * n.y * a;
    *t = v3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = v3(c, sign + n.y * n.y * a, -n.y);
}

#endif
