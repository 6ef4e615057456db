/* What the host hands the OpenCL cone kernel (tracer/backends/opencl/opencl_cone.c -> tracer/backends/opencl/cl/render_cone.cl):
 * one parameter block, compiled on both sides so that the layouts agree (only double, 64/32-bit
 * integers, float, vec3, camera and light, which C on x86-64 and OpenCL C lay out alike; the
 * program checks sizeof against the host's, VX_CL_PARAMS_BYTES). */
#ifndef VX_CL_RENDER_CONE_PARAMS_H
#define VX_CL_RENDER_CONE_PARAMS_H

#include "counters.h"
#include "camera.h"
#include "grid_params.h"
#include "light.h"
#include "model.h"
#include "shadow_params.h"

typedef struct {
    vx_cl_grid_params grid;
    uint64_t dilated_off[GRID_MAX_LEVELS];  /* where each level's dilated bitmap starts (cone_skip.h) */
    uint64_t light_cache_mask;              /* slots - 1; the cache is off when use_light_cache is 0 */
    camera cam;
    vec3 background;
    light lights[VX_MAX_LIGHTS];
    float spread;                           /* footprint radius per unit distance (camera_pixel_spread) */
    int dilated_n[GRID_MAX_LEVELS];         /* 0: no bitmap for the level */
    int dilated_wpc[GRID_MAX_LEVELS];
    int width, height;
    int light_count;
    unsigned effects;                       /* VX_EFFECT_* */
    int use_light_cache;
    vx_cl_shadow_params shadows;            /* precomputed shadows (none: method march) */
} vx_cl_cone_params;

/* Pixels a work-item takes at a time from the shared tile counter (see vx_render_cone): small
 * enough that the last tiles even out the threads' finishing times, large enough that the counter
 * is rarely touched. One on a wide launch (a GPU), as VX_CL_TILE_PIXELS. */
#ifdef VX_CL_WIDE
#define VX_CONE_TILE_PIXELS 1
#else
#define VX_CONE_TILE_PIXELS 16
#endif

#endif
