/* The OpenCL host of the cone marcher (cl/render_cone.cl, which runs render_cone_core.h, the C
 * backend's marcher): uploads the grid, the records of every level, the model's table, the dilated
 * occupancy bitmaps and an empty light cache, and runs vx_render_cone (opencl_host.c's persistent
 * tiles). opencl_backend.c opens the device and hands cone-evaluation models here. */
#include "opencl_cone.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "cl/render_cone_params.h"
#include "cone_light_cache.h"
#include "cone_skip.h"
#include "opencl_host.h"
#include "parallel.h"

/* vx_render_cone's buffer arguments, in order (render_cone.cl), then the pixel count. */
enum { C_PARAMS, C_COLS, C_BITS, C_PREFIX, C_RECORDS, C_TABLE, C_DILATED, C_LC_KEYS, C_LC_STATE, C_LC_T, C_SHADOWS,
       C_IMAGE, C_COUNTS, C_NEXT_TILE, C_N };

static void fill_params(vx_cl_cone_params *p, const scene *s, const voxel_grid *g, const dilated_grid *d,
                        const render_options *o, size_t lc_slots, const shadow_set *maps)
{
    memset(p, 0, sizeof *p);
    vx_cl_grid_params_fill(&p->grid, g);
    uint64_t dil = 0;
    for (int l = 0; l < g->levels; l++) {
        p->dilated_off[l] = dil;
        p->dilated_n[l] = d->level[l].w ? d->level[l].n : 0;
        p->dilated_wpc[l] = d->level[l].w ? d->level[l].wpc : 0;
        dil += dilated_words(d, l);
    }
    p->cam = s->camera;
    p->background = s->background;
    p->light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    for (int i = 0; i < p->light_count; i++)
        p->lights[i] = s->lights[i];
    p->spread = camera_pixel_spread(&s->camera, o->height);
    p->width = o->width;
    p->height = o->height;
    p->effects = s->effects;
    /* The same rule as the C backend (render_cone.c): shadows declared, lights, the cache on, no
     * precomputed shadow maps. */
    p->use_light_cache = o->cache && (s->effects & EFFECT_SHADOWS) && p->light_count > 0 && !maps;
    p->light_cache_mask = lc_slots - 1;
    vx_cl_shadow_params_fill(&p->shadows, maps);
}

/* The dilated bitmaps, level after level (offsets in the parameters), queued without blocking. */
static int upload_dilated(opencl_launch *L, const dilated_grid *skip, int levels, vx_err *e)
{
    size_t dil = 0;
    for (int l = 0; l < levels; l++)
        dil += dilated_words(skip, l);
    if (opencl_launch_buffer(L, C_DILATED, CL_MEM_READ_ONLY, dil * sizeof(uint64_t), NULL, e))
        return -1;
    size_t dw = 0;
    for (int l = 0; l < levels; l++) {
        size_t nd = dilated_words(skip, l);
        if (nd && opencl_check(clEnqueueWriteBuffer(L->rt->queue, L->buf[C_DILATED], CL_FALSE, dw * sizeof(uint64_t),
                                                    nd * sizeof(uint64_t), skip->level[l].w, 0, NULL, NULL),
                               "uploading the occupancy bitmaps", e))
            return -1;
        dw += nd;
    }
    return 0;
}

static int render(opencl_launch *L, dilated_grid *skip, const opencl_runtime *rt, const scene *s, const voxel_grid *g,
                  const vx_model *m, const void *records, const render_options *o, const shadow_set *maps, image *out,
                  render_counts *counts, backend_counts *bc, const char *build_dir, vx_err *e)
{
    size_t pixels = (size_t)o->width * (size_t)o->height;
    /* Built before the clock starts, as the C backend (render_cone.c) builds its own: a like-for-like
     * render time. Their upload is the render's set-up (setup_seconds), as the C backend's. */
    if (dilated_build(skip, g))
        return vx_fail(e, "out of memory for the cone marcher's occupancy bitmaps");
    size_t table_bytes = 0;
    const void *table = m->cone->table ? m->cone->table(&table_bytes) : NULL;
    opencl_clock c = {.start = now_seconds()};
    char defines[256];
    snprintf(defines, sizeof defines, "#define VX_CL_CONE_ELEMENT %s\n#define VX_CL_PARAMS_BYTES %zu\n",
             m->cone->element.name, sizeof(vx_cl_cone_params));
    if (opencl_launch_build(L, rt, m, defines, "render_cone.cl", "vx_render_cone", C_N, C_NEXT_TILE,
                            build_dir, e))
        return -1;
    c.compiled = now_seconds();
    size_t lc_slots = cone_light_cache_slots(cone_light_cache_cells(grid_count(g, 0), pixels));
    vx_cl_cone_params params;
    fill_params(&params, s, g, skip, o, lc_slots, maps);
    size_t lc = params.use_light_cache ? lc_slots : 0, lights = params.light_count > 0 ? (size_t)params.light_count : 1;
    size_t record_count = 0;
    for (int l = 0; l < g->levels; l++)
        record_count += grid_count(g, l);
    /* The records and the table are used in place (they outlive the render): on a CPU device
     * (PoCL) no copy, as the C backend reads them; a GPU's driver copies them. */
    const cl_mem_flags RO = CL_MEM_READ_ONLY, RW = CL_MEM_READ_WRITE;
    if (opencl_launch_buffer(L, C_PARAMS, RO, sizeof params, &params, e) ||
        opencl_launch_grid(L, C_COLS, C_BITS, C_PREFIX, g, e) ||
        opencl_launch_grid_upload(L, C_COLS, C_BITS, C_PREFIX, g, e) || upload_dilated(L, skip, g->levels, e) ||
        opencl_launch_buffer(L, C_RECORDS, RO | CL_MEM_USE_HOST_PTR, record_count * m->record.bytes, records, e) ||
        opencl_launch_buffer(L, C_TABLE, RO | CL_MEM_USE_HOST_PTR, table_bytes, table, e) ||
        opencl_launch_buffer(L, C_LC_KEYS, RW, lc * sizeof(uint64_t), NULL, e) ||
        opencl_launch_buffer(L, C_LC_STATE, RW, lc * sizeof(cl_int), NULL, e) ||
        opencl_launch_buffer(L, C_LC_T, RW, lc * lights * sizeof(float), NULL, e) ||
        opencl_launch_buffer(L, C_SHADOWS, RO | CL_MEM_USE_HOST_PTR, maps ? maps->bytes : 0, maps ? maps->block : NULL,
                             e) ||
        opencl_launch_buffer(L, C_IMAGE, CL_MEM_WRITE_ONLY, pixels * 3 * sizeof(float), NULL, e) ||
        opencl_launch_counters(L, C_COUNTS, e) || opencl_launch_buffer(L, C_NEXT_TILE, RW, sizeof(cl_int), NULL, e) ||
        opencl_launch_zero(L, C_LC_KEYS, lc * sizeof(uint64_t), e) ||
        opencl_launch_zero(L, C_LC_STATE, lc * sizeof(cl_int), e))
        return -1;
    /* The uploads and clears complete now, in the render's set-up: left queued they would run in
     * the warm-up launch below, which counts as compile time. */
    if (opencl_check(clFinish(rt->queue), "uploading the grid and clearing the light cache", e))
        return -1;
    c.bound = now_seconds();
    if (opencl_launch_warm_up(L, &c, e))
        return -1;
    return opencl_launch_render(L, &c, (int)pixels, "running vx_render_cone", C_IMAGE, out->data, C_COUNTS, counts, bc,
                                e);
}

int opencl_render_cone(const opencl_runtime *rt, const scene *s, const voxel_grid *g, const vx_model *m,
                       const void *records, const render_options *o, image *out, render_counts *counts,
                       backend_counts *bc, const char *build_dir, vx_err *e)
{
    /* The precomputed shadows, as the C backend builds them, before the render's clock. */
    shadow_request sr = {o->shadow_method, o->shadow_res, o->threads, slicemap_fill_model};
    const shadow_set *maps = NULL;
    shadow_stats sst;
    if (render_shadow_method_refused(s, m, o, e))
        return -1;
    if (shadow_prepare(s, g, m, records, &sr, &maps, &sst, e))
        return -1;
    opencl_launch L;
    dilated_grid skip;
    memset(&L, 0, sizeof L);
    memset(&skip, 0, sizeof skip);
    int rc = render(&L, &skip, rt, s, g, m, records, o, maps, out, counts, bc, build_dir, e);
    opencl_launch_release(&L);
    dilated_free(&skip);
    shadow_release(maps);
    if (!rc) {
        uint64_t queries = counts->shadows.queries;
        counts->shadows = sst;
        counts->shadows.queries = queries;
    }
    return rc;
}
