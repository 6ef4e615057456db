/* A scene's light and the light it sends to a point: shared by the ground truth, both voxel tracers
 * and the OpenCL kernel (tracer/backends/opencl/cl/render.cl includes this file; the host copies scene lights into
 * its parameter block as they are), so every renderer lights a point alike. Portable C: no libc
 * beyond <math.h>, and a layout that C and OpenCL C define alike. */
#ifndef VX_LIGHT_H
#define VX_LIGHT_H

#include "vec.h"

enum { LIGHT_DIRECTIONAL = 0, LIGHT_POINT = 1 };

/* A scene's lights at most. The voxel and cone tracers hold a voxel's or an element's lights in
 * fixed arrays (model.h's VX_MAX_LIGHTS, which render.c checks is as large), so the scene reader
 * refuses more: lit by its first ones only, a model would be judged against a truth lit by all. */
#define LIGHT_MAX_COUNT 8

typedef struct {
    int type;
    vec3 direction; /* directional: unit vector from the scene toward the light */
    vec3 position;  /* point light */
    vec3 radiance;  /* directional: irradiance on a facing surface; point: intensity (W/sr) */
} light;

/* Unit direction and irradiance from light L at point p (irradiance on a surface facing the light;
 * the caller applies the cosine). *distance is the light's distance (INFINITY for directional). */
VX_INLINE void light_at(const light *L, vec3 p, vec3 *to_light, vec3 *irradiance, float *distance)
{
    if (L->type == LIGHT_DIRECTIONAL) {
        *to_light = L->direction;
        *irradiance = L->radiance;
        *distance = INFINITY;
        return;
    }
    vec3 d = v3_sub(L->position, p);
    float d2 = vx_fmaxf(v3_dot(d, d), 1e-20f);
    *distance = sqrtf(d2);
    *to_light = v3_scale(d, 1.0f / *distance);
    *irradiance = v3_scale(L->radiance, 1.0f / d2);
}

#endif
