/* The OpenCL cone tracer: tracer/render/render_cone_core.h (the C backend's cone marcher, the same
 * file) as one kernel, persistent work-items taking tiles of pixels. opencl_cone.c has the program
 * assembled (opencl_program.c): prelude.h, the model's portable source, then this file, with
 *   VX_CL_CONE_ELEMENT   the model's cone element function (by name)
 *   VX_CL_PARAMS_BYTES   sizeof(vx_cl_cone_params) on the host
 * The light cache is shared by all work-items as the C backend's is by its threads: a value depends
 * only on its cell, so the image does not depend on the order in which work-items run. */
#include "camera.h"
#include "flush_counts.h"
#include "render_cone_params.h"

#define CONE_ELEMENT(x, q, a) VX_CL_CONE_ELEMENT(q, a)
#include "render_cone_core.h"

/* A mismatch between the host's and this compiler's layout would read garbage: refuse to build. */
typedef char vx_cl_cone_params_size_matches_host[sizeof(vx_cl_cone_params) == VX_CL_PARAMS_BYTES ? 1 : -1];

/* Persistent work-items: each takes the next tile of VX_CONE_TILE_PIXELS consecutive pixels from
 * the shared counter *next_tile until none is left, so the work goes to whoever is free, as the C
 * tracer's threads take rows (parallel_for). A fixed split (one work-item per pixel, the runtime
 * handing each thread its share of the work-groups up front: PoCL gives each of 2 threads half of
 * them) leaves one core idle at the end whenever the shares cost unlike amounts. The host launches
 * one work-group per compute unit; on a CPU device a group runs its work-items one after the other
 * on one thread, so the first takes tiles until the image is done and the rest find none (on a GPU,
 * VX_CL_WIDE: 16 groups per compute unit, one pixel at a time). Which
 * work-item renders a pixel changes nothing in it (the light cache's values depend only on their
 * cell). counts: one slot per work-group. */
__kernel void vx_render_cone(__global const vx_cl_cone_params *P, __global ulong *cols, __global ulong *bits,
                             __global uint *prefix, __global const uchar *records, __global const uint *table,
                             __global ulong *dilated, __global ulong *lc_keys, __global int *lc_state,
                             __global float *lc_T, __global const uchar *shadow_block, __global float *image,
                             __global uint *counts,
                             volatile __global int *next_tile, int pixels)
{
    voxel_grid g;
    vx_cl_grid_from_params(&g, &P->grid, cols, bits, prefix);
    dilated_grid d;
    for (int l = 0; l < GRID_MAX_LEVELS; l++) {
        int on = l < P->grid.levels && P->dilated_n[l] > 0;
        d.level[l].n = on ? P->dilated_n[l] : 0;
        d.level[l].wpc = on ? P->dilated_wpc[l] : 0;
        d.level[l].w = on ? dilated + P->dilated_off[l] : 0;
    }
    cone_light_cache lc;
    lc.keys = lc_keys;
    lc.state = lc_state;
    lc.T = lc_T;
    lc.mask = P->light_cache_mask;
    lc.lights = P->light_count < VX_MAX_LIGHTS ? P->light_count : VX_MAX_LIGHTS;
    cone_ctx x;
    x.g = &g;
    x.skip = &d;
    x.records = records;
    x.table = table;
    x.lcache = P->use_light_cache ? &lc : 0;
    x.light_count = P->light_count < VX_MAX_LIGHTS ? P->light_count : VX_MAX_LIGHTS;
    for (int li = 0; li < x.light_count; li++)
        x.lights[li] = P->lights[li];
    x.effects = P->effects;
    vx_cl_shadow_maps(&x.shadows, &P->shadows, shadow_block);
    x.counts.elements = x.counts.shadow_rays = x.counts.evals = x.counts.cache_hits = 0;
    int width = P->width, height = P->height;
    camera cam = P->cam; /* camera_ray takes a private pointer */
    int dof = (P->effects & VX_EFFECT_DOF) && cam.aperture_radius > 0.0f;
    float spread = P->spread;
    vec3 background = P->background;
    ulong rays = 0; /* one cone per pixel */
    int tiles = (pixels + VX_CONE_TILE_PIXELS - 1) / VX_CONE_TILE_PIXELS;
    for (int tile = atomic_inc(next_tile); tile < tiles; tile = atomic_inc(next_tile)) {
        int end = min(pixels, (tile + 1) * VX_CONE_TILE_PIXELS);
        for (int pix = tile * VX_CONE_TILE_PIXELS; pix < end; pix++) {
            int px = pix % width, py = pix / width;
            /* The pixel's centre ray from the lens centre (render_cone.c's cone_row). */
            vec3 org, dir;
            camera_ray(&cam, width, height, (float)px + 0.5f, (float)py + 0.5f, 0.5f, 0.5f, 0, &org, &dir);
            rays++;
            vec3 c = cone_trace(&x, org, dir, spread, dof ? cam.aperture_radius : 0.0f, cam.focus_distance,
                                cam.forward, background);
            __global float *dst = &image[3 * (size_t)pix];
            dst[0] = c.x;
            dst[1] = c.y;
            dst[2] = c.z;
        }
    }
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_RAYS, rays);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_SHADOW_RAYS, x.counts.shadow_rays);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_VISITS, x.counts.elements);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_EVALS, x.counts.evals);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_CACHE_HITS, x.counts.cache_hits);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_SHADOW_QUERIES, x.shadows.queries);
}
