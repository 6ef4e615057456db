/* What the host hands the OpenCL tracer (opencl_voxel.c -> cl/render.cl): one
 * parameter block and the cache entry, compiled on both sides so that the layouts agree. Only types
 * whose size and alignment C on x86-64 and OpenCL C define alike (double, 64/32-bit integers, float,
 * vec3 = three floats, and camera.h's camera and light.h's light, made of those); the program checks
 * sizeof against the host's (VX_CL_PARAMS_BYTES). */
#ifndef VX_CL_RENDER_PARAMS_H
#define VX_CL_RENDER_PARAMS_H

#include "camera.h"
#include "counters.h"
#include "grid_params.h"
#include "light.h"
#include "model.h"
#include "shadow_params.h"

typedef struct {
    vx_cl_grid_params grid;
    uint64_t seed;
    camera cam;               /* the scene's, as it is */
    vec3 background;
    light lights[VX_MAX_LIGHTS];
    float spread;             /* footprint radius per unit distance (camera_pixel_spread) */
    float stop_opacity;
    int width, height, spp;
    int strata_x, strata_y;   /* truth_strata(spp) */
    int light_count;
    unsigned effects;         /* VX_EFFECT_* */
    int shadow_skip, cache;
    int voxel_count;          /* non-empty level-0 voxels */
    int memo_lights;          /* the directional lights' opacity memo: slots per voxel, 0 = none */
    float view_tile;          /* the cached opacities' direction lattice (view_tile.h); 0: exact */
    int shadow_T_lights;      /* the voxel shadow method's transmittances: slots per voxel, 0 = none */
    vx_cl_shadow_params shadows; /* precomputed shadows (none: method march) */
} vx_cl_params;

/* Pixels a work-item takes at a time from the shared tile counter (see vx_render). On a CPU: small
 * enough that the last tiles even out the threads' finishing times (a tile is ~1/1000 of a 256x256
 * render), large enough that the counter is rarely touched and that the threads seldom share cache
 * lines of the image and the shading cache; 64 measured faster than 16 and than whole 256-pixel
 * rows. A wide launch (VX_CL_WIDE, a GPU: opencl_host.h) takes one pixel at a time, so that a
 * 256x256 image keeps 65,536 work-items busy, not 1,024, and the neighbours of a warp take
 * neighbouring pixels. */
#ifdef VX_CL_WIDE
#define VX_CL_TILE_PIXELS 1
#else
#define VX_CL_TILE_PIXELS 64
#endif

/* A voxel's answer for the direction voxel -> camera (the C tracer's cache_entry; its state is a
 * separate int array, zeroed by the host). */
typedef struct {
    float radiance[3];
    float opacity;
} vx_cl_cache;


#endif
