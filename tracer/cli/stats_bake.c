/* The --stats fields of a bake (bake and render): apart from stats.c, which the truth uses too, so
 * that the truth's code path holds none of the bake's. */
#include "bake_params.h"
#include "parallel.h"
#include "stats.h"

void stats_add_bake(cJSON *j, const vx_model *m, const struct vx_bake_params *params, const voxel_grid *g,
                    const bake_counts *c, int rays, double grid_seconds)
{
    cJSON_AddStringToObject(j, "model", m->name);
    struct vx_bake_params defaults;
    if (!params) {
        bake_params_defaults(m, &defaults);
        params = &defaults;
    }
    char text[256];
    if (bake_params_format(m, params, text, sizeof text) == 0)
        cJSON_AddStringToObject(j, "model_params", text);
    cJSON_AddNumberToObject(j, "res", g->n);
    cJSON_AddNumberToObject(j, "voxels", (double)grid_count(g, 0));
    cJSON_AddNumberToObject(j, "bytes_per_voxel", (double)m->record.bytes);
    cJSON_AddNumberToObject(j, "records", (double)bake_record_count(m, g));
    cJSON_AddNumberToObject(j, "model_bytes", (double)(bake_record_count(m, g) * m->record.bytes));
    cJSON_AddNumberToObject(j, "grid_bytes", (double)grid_bytes(g));
    cJSON_AddNumberToObject(j, "grid_seconds", grid_seconds);
    if (c->seconds < 0) { /* rendered from a .vox file: the bake's time is in that bake's --stats */
        cJSON_AddNullToObject(j, "bake_seconds");
        cJSON_AddNullToObject(j, "bake_pass_seconds");
        cJSON_AddNullToObject(j, "bake_sampling_seconds");
        cJSON_AddNullToObject(j, "bake_finish_seconds");
    } else {
        /* The model's own: its part of the sampling pass (bake_counts.seconds) and its bake_finish. */
        cJSON_AddNumberToObject(j, "bake_seconds", c->seconds + c->finish_seconds);
        cJSON_AddNumberToObject(j, "bake_pass_seconds", c->pass_seconds);
        cJSON_AddNumberToObject(j, "bake_sampling_seconds", c->sampling_seconds);
        cJSON_AddNumberToObject(j, "bake_finish_seconds", c->finish_seconds);
    }
    cJSON_AddNumberToObject(j, "bake_rays", (double)c->rays);
    cJSON_AddNumberToObject(j, "rays_per_voxel", rays);
}

cJSON *stats_bake(const scene *s, const vx_model *m, const bake_options *o, const voxel_grid *g, const bake_counts *c,
                  double grid_seconds)
{
    cJSON *j = stats_scene_fields(s);
    cJSON_AddStringToObject(j, "command", "bake");
    stats_add_bake(j, m, &o->params, g, c, o->rays, grid_seconds);
    cJSON_AddNumberToObject(j, "seconds", c->seconds + c->finish_seconds);
    cJSON_AddNumberToObject(j, "rays", (double)c->rays);
    cJSON_AddNumberToObject(j, "shadow_rays", 0);
    cJSON_AddNumberToObject(j, "bake_rays_per_second", (double)c->rays / c->seconds);
    cJSON_AddNumberToObject(j, "threads", parallel_threads(o->threads));
    cJSON_AddNumberToObject(j, "peak_rss_bytes", peak_rss_bytes());
    return j;
}

cJSON *stats_render(const scene *s, const vx_model *m, const bake_options *bo, const voxel_grid *g,
                    const bake_counts *bc, double grid_seconds, const vx_backend *b, const render_options *o,
                    const render_counts *rc, const backend_counts *bcnt)
{
    cJSON *j = stats_scene_fields(s);
    cJSON_AddStringToObject(j, "command", "render");
    stats_add_bake(j, m, &bo->params, g, bc, bo->rays, grid_seconds);
    cJSON_AddStringToObject(j, "backend", b->name);
    /* The model's constant table (heitz-neyret's coverage masks, 1 MiB), read at every evaluation
     * on either backend: memory the model needs beside its records, whatever the grid (issue 15's
     * audit: it was in no memory figure). Already built by the render, so asking costs nothing. */
    size_t table_bytes = 0;
    if (m->cone && m->cone->table)
        m->cone->table(&table_bytes);
    cJSON_AddNumberToObject(j, "table_bytes", (double)table_bytes);
    cJSON_AddNumberToObject(j, "seconds", rc->seconds);
    if (b->splits_model_time) {
        cJSON_AddNumberToObject(j, "traversal_seconds", rc->traversal_seconds);
        cJSON_AddNumberToObject(j, "model_seconds", rc->model_seconds);
        /* Minor page faults inside `seconds`: memory the render threads touched first, each fault a
         * stall and a TLB shootdown of the other cores (issue 15). Near 0 when the render's buffers
         * were pre-faulted; a large number here means a timed frame paid for allocation. */
        cJSON_AddNumberToObject(j, "render_page_faults", (double)rc->page_faults);
    } else {
        cJSON_AddNullToObject(j, "traversal_seconds");
        cJSON_AddNullToObject(j, "model_seconds");
        cJSON_AddNullToObject(j, "render_page_faults"); /* the device's memory: not this process's faults */
    }
    /* Every backend's set-up outside `seconds`: the C backend's caches and maps, OpenCL's buffers
     * and their upload. */
    cJSON_AddNumberToObject(j, "setup_seconds", rc->setup_seconds);
    if (b->has_device) /* NAME_compile_seconds ...: compile time is apart from seconds */
        stats_add_backend(j, b->name, bcnt);
    cJSON_AddNumberToObject(j, "rays", (double)rc->rays);
    cJSON_AddNumberToObject(j, "shadow_rays", (double)rc->shadow_rays);
    stats_add_shadows(j, &rc->shadows);
    cJSON_AddNumberToObject(j, "voxel_visits", (double)rc->voxel_visits);
    cJSON_AddNumberToObject(j, "model_evals", (double)rc->model_evals);
    cJSON_AddNumberToObject(j, "cache_hits", (double)rc->cache_hits);
    cJSON_AddNumberToObject(j, "shadow_memo_hits", (double)rc->memo_hits);
    cJSON_AddBoolToObject(j, "cache", o->cache);
    /* The cached opacities' direction lattice in pixels (tracer/render/view_tile.h), 0: the exact
     * direction voxel -> camera. */
    cJSON_AddNumberToObject(j, "view_tile_pixels", (double)render_view_tile_pixels(m, o));
    if (b->has_device) {
        cJSON_AddNullToObject(j, "cache_bytes"); /* the device's buffers, sized by its backend */
        cJSON_AddNullToObject(j, "map_bytes");
    } else {
        cJSON_AddNumberToObject(j, "cache_bytes", (double)rc->cache_bytes);
        cJSON_AddNumberToObject(j, "map_bytes", (double)rc->map_bytes);
    }
    cJSON_AddBoolToObject(j, "shadow_skip", o->shadow_skip);
    stats_add_image(j, o->spp, o->width, o->height, o->seed, o->threads);
    return j;
}
