/* The OpenCL host of the voxel marcher (cl/render.cl, a thin driver of render_voxel_core.h): the
 * parameter block, the buffers (grid, records and image used in place, the shading cache), and the
 * render's timing, split as the C backend's: compile and the warm-up launch apart from the render. */
#include "opencl_voxel.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "cl/render_params.h"
#include "opencl_host.h"
#include "parallel.h"
#include "shadow_memo.h"
#include "strata.h"
#include "view_tile.h"

/* vx_render's buffer arguments, in order (render.cl), then the pixel count. */
enum {
    B_PARAMS, B_COLS, B_BITS, B_PREFIX, B_RECORDS, B_CACHE, B_STATE, B_MEMO, B_SHADOWS, B_SHADOW_T, B_IMAGE, B_COUNTS,
    B_NEXT_TILE, B_N
};

static void fill_params(vx_cl_params *p, const scene *s, const voxel_grid *g, const render_options *o,
                        const shadow_set *maps)
{
    memset(p, 0, sizeof *p);
    vx_cl_grid_params_fill(&p->grid, g);
    p->seed = o->seed;
    p->cam = s->camera;
    p->background = s->background;
    p->light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    for (int i = 0; i < p->light_count; i++)
        p->lights[i] = s->lights[i];
    p->spread = camera_pixel_spread(&s->camera, o->height);
    p->stop_opacity = o->stop_opacity;
    p->width = o->width;
    p->height = o->height;
    p->spp = o->spp;
    truth_strata(o->spp, &p->strata_x, &p->strata_y);
    p->effects = s->effects;
    p->shadow_skip = o->shadow_skip;
    p->cache = o->cache;
    p->voxel_count = (int)grid_count(g, 0);
    vx_cl_shadow_params_fill(&p->shadows, maps);
}

/* shadow_T (shadow_T_bytes): the voxel method's transmittances (render_voxel_shadows), or NULL. */
static int render(opencl_launch *L, const opencl_runtime *rt, const scene *s, const voxel_grid *g, const vx_model *m,
                  const void *records, const render_options *o, const shadow_set *maps, const float *shadow_T,
                  size_t shadow_T_bytes, image *out, render_counts *counts, backend_counts *bc, const char *build_dir,
                  vx_err *e)
{
    size_t voxels = grid_count(g, 0), pixels = (size_t)o->width * (size_t)o->height;
    opencl_clock c = {.start = now_seconds()};
    char defines[512];
    snprintf(defines, sizeof defines,
             "#define VX_CL_OPACITY %s\n#define VX_CL_SHADE %s\n#define VX_CL_COMPOSITING %d\n"
             "#define VX_CL_RECORD_BYTES %zu\n#define VX_CL_PARAMS_BYTES %zu\n",
             m->voxel->opacity.name, m->voxel->shade.name, m->voxel->compositing, m->record.bytes,
             sizeof(vx_cl_params));
    if (m->voxel->transmit.fn) {
        size_t used = strlen(defines);
        snprintf(defines + used, sizeof defines - used, "#define VX_CL_TRANSMIT %s\n", m->voxel->transmit.name);
    }
    if (opencl_launch_build(L, rt, m, defines, "render.cl", "vx_render", B_N, B_NEXT_TILE, build_dir, e))
        return -1;
    c.compiled = now_seconds();
    vx_cl_params params;
    fill_params(&params, s, g, o, maps);
    /* With the transmittances precomputed the frame casts no shadow ray: no memo. */
    params.memo_lights = shadow_T ? 0 : render_shadow_memo_lights(s, m, maps);
    params.shadow_T_lights = shadow_T ? params.light_count : 0;
    params.view_tile = view_tile_width(render_view_tile_pixels(m, o), params.spread);
    size_t cached = o->cache ? voxels : 0, memo_bytes = voxels * (size_t)params.memo_lights * sizeof(cl_uint);
    const cl_mem_flags RO = CL_MEM_READ_ONLY, RW = CL_MEM_READ_WRITE;
    /* The kernel only reads the records and only writes the image: both used in place. */
    if (opencl_launch_buffer(L, B_PARAMS, RO, sizeof params, &params, e) ||
        opencl_launch_buffer(L, B_RECORDS, RO | CL_MEM_USE_HOST_PTR, voxels * m->record.bytes, records, e) ||
        opencl_launch_buffer(L, B_CACHE, RW, cached * sizeof(vx_cl_cache), NULL, e) ||
        opencl_launch_buffer(L, B_STATE, RW, cached * sizeof(cl_int), NULL, e) ||
        opencl_launch_buffer(L, B_MEMO, RW, memo_bytes, NULL, e) ||
        opencl_launch_buffer(L, B_SHADOWS, RO | CL_MEM_USE_HOST_PTR, maps ? maps->bytes : 0, maps ? maps->block : NULL,
                             e) ||
        opencl_launch_buffer(L, B_SHADOW_T, RO | CL_MEM_USE_HOST_PTR, shadow_T ? shadow_T_bytes : 0, shadow_T, e) ||
        opencl_launch_buffer(L, B_IMAGE, CL_MEM_WRITE_ONLY | CL_MEM_USE_HOST_PTR, pixels * 3 * sizeof(float), out->data,
                             e) ||
        opencl_launch_counters(L, B_COUNTS, e) || opencl_launch_buffer(L, B_NEXT_TILE, RW, sizeof(cl_int), NULL, e) ||
        opencl_launch_grid(L, B_COLS, B_BITS, B_PREFIX, g, e))
        return -1;
    c.bound = now_seconds();
    /* The warm-up reads none of the grid, the cache or the image: it runs on the empty buffers. */
    if (opencl_launch_warm_up(L, &c, e))
        return -1;
    /* The grid's upload and the clearing of the cache are the render's set-up, waited for apart
     * and reported as setup_seconds, as the C backend's caches and maps are made before its clock:
     * the two backends' `seconds` time the same work (one more wait, a wake-up of PoCL's threads). */
    if (opencl_launch_zero(L, B_STATE, cached * sizeof(cl_int), e) ||
        opencl_launch_fill(L, B_MEMO, memo_bytes, SHADOW_MEMO_EMPTY, e) ||
        opencl_launch_grid_upload(L, B_COLS, B_BITS, B_PREFIX, g, e) ||
        opencl_launch_set_up(L, &c, "uploading the grid and clearing the caches", e))
        return -1;
    return opencl_launch_render(L, &c, (int)pixels, "running vx_render", B_IMAGE, out->data, B_COUNTS, counts, bc, e);
}

int opencl_render_voxels(const opencl_runtime *rt, const scene *s, const voxel_grid *g, const vx_model *m,
                         const void *records, const render_options *o, image *out, render_counts *counts,
                         backend_counts *bc, const char *build_dir, vx_err *e)
{
    /* The precomputed shadows, as the C backend builds them (the same maps, the same transmittances
     * per voxel: the same image), before the render's clock; uploaded in place. */
    shadow_request sr = {o->shadow_method, o->shadow_res, o->threads, slicemap_fill_model};
    const shadow_set *maps = NULL;
    shadow_stats sst;
    if (shadow_prepare(s, g, m, records, &sr, &maps, &sst, e))
        return -1;
    float *shadow_T = NULL;
    size_t shadow_T_bytes = 0;
    if (sst.method == SHADOW_VOXEL) {
        if (render_voxel_shadows(s, g, m, records, o, &shadow_T, &shadow_T_bytes, &sst.build_seconds, e))
            return -1;
        sst.bytes = shadow_T_bytes;
    }
    opencl_launch L;
    memset(&L, 0, sizeof L);
    int rc = render(&L, rt, s, g, m, records, o, maps, shadow_T, shadow_T_bytes, out, counts, bc, build_dir, e);
    opencl_launch_release(&L);
    shadow_release(maps);
    free(shadow_T);
    if (!rc) {
        uint64_t queries = counts->shadows.queries;
        counts->shadows = sst;
        counts->shadows.queries = queries;
    }
    return rc;
}
