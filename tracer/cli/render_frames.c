/* The frame loop of `voxlab render --frame/--frames/--filter` (render_frames.h). */
#include "render_frames.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "animation.h"
#include "bake_params.h"
#include "dynamic.h"
#include "parallel.h"
#include "stats.h"

int render_frames(scene *s, const vx_model *m, int res, const bake_options *bo, const render_options *o,
                  const vx_backend *backend, const char *out_path, const char *stats_path, const frame_range *fr,
                  int filter, int argc, char **argv, vx_err *e)
{
    frame_range range = *fr; /* resolved already by cmd_render; not by every caller */
    if (frames_resolve(s, &range, e) || backend->check(m, o, e))
        return -1;
    int first = range.first, last = range.last, ref = s->anim ? s->anim->first : 0;
    int used = filter;
    const char *fallback = NULL;
    if (filter != DYN_REBAKE && !(m->transform && m->combine)) {
        /* Said, not hidden: the figures of this run are a re-bake's. */
        fallback = "the model has no transform/combine: moving objects re-baked every frame";
        fprintf(stderr, "voxlab render: --filter %s: model %s has no transform/combine; falling back to rebake\n",
                dyn_filter_name(filter), m->name);
        used = DYN_REBAKE;
    }
    dyn_scene d = {0};
    if (used != DYN_REBAKE && (scene_set_frame(s, ref, e) || dyn_prepare(&d, s, m, res, bo, e)))
        return -1;
    int rc = -1, f = first;
    for (; f <= last; f++) {
        char out_f[4096], stats_f[4096];
        frames_path(out_path, f, out_f, sizeof out_f);
        if (stats_path)
            frames_path(stats_path, f, stats_f, sizeof stats_f);
        const char *out = fr->sequence ? out_f : out_path, *stats = !stats_path ? NULL : fr->sequence ? stats_f : stats_path;
        voxel_grid g;
        void *records = NULL;
        bake_counts bc = {0};
        dyn_counts dc = {0};
        double grid_seconds = 0, t0 = now_seconds();
        if (scene_set_frame(s, f, e))
            goto fail;
        if (used == DYN_REBAKE ? bake_scene(s, m, res, bo, &g, &records, &bc, &grid_seconds, e)
                               : dyn_frame(&d, s, f, used, &g, &records, &dc, e))
            goto fail;
        double build_seconds = now_seconds() - t0;
        if (used != DYN_REBAKE)
            grid_seconds = dc.grid_seconds;
        image_meta meta;
        provenance_common(&meta, argc, argv, s, o->width, o->height, o->spp, o->seed);
        image_meta_add(&meta, "renderer", "%s backend", backend->name);
        image_meta_add(&meta, "model", "%s", m->name);
        image_meta_add(&meta, "res", "%d", g.n);
        image_meta_add(&meta, "rays", "%d", bo->rays);
        image_meta_add(&meta, "frame", "%d", f);
        image_meta_add(&meta, "filter", "%s", dyn_filter_name(used));
        char params[256];
        if (bake_params_format(m, &bo->params, params, sizeof params) == 0)
            image_meta_add(&meta, "model_params", "%s", params);
        image img = {0};
        render_counts rcnt;
        backend_counts bcnt = {0};
        int bad = backend->render(s, &g, m, records, o, &img, &rcnt, &bcnt, e);
        img.meta = &meta;
        bad = bad || image_write(&img, out, e);
        if (!bad && stats) {
            cJSON *j = stats_render(s, m, bo, &g, &bc, grid_seconds, backend, o, &rcnt, &bcnt);
            cJSON_AddNumberToObject(j, "frame", f);
            cJSON_AddStringToObject(j, "filter", dyn_filter_name(filter));
            cJSON_AddStringToObject(j, "filter_used", dyn_filter_name(used));
            if (fallback)
                cJSON_AddStringToObject(j, "fallback", fallback);
            /* The frame's voxels: a re-bake (grid + bake) or the transformation (placing, sorting,
             * combining + the world grid); the parts' one-time bake apart. */
            cJSON_AddNumberToObject(j, "frame_voxels_seconds", build_seconds);
            cJSON_AddNumberToObject(j, used == DYN_REBAKE ? "rebake_seconds" : "transform_seconds", build_seconds);
            if (used != DYN_REBAKE) {
                cJSON_AddNumberToObject(j, "prepare_bake_seconds", d.bake_seconds);
                cJSON_AddNumberToObject(j, "moving_objects", d.parts - 1);
                cJSON_AddNumberToObject(j, "record_parts", (double)dc.parts_in);
                cJSON_AddNumberToObject(j, "parts_outside_grid", (double)dc.dropped);
            }
            bad = stats_finish(j, stats, "render", out) != 0;
            if (bad)
                vx_fail(e, "%s: could not write the statistics", stats);
        }
        image_free(&img);
        free(records);
        grid_free(&g);
        if (bad)
            goto fail;
    }
    rc = 0;
fail:
    if (rc && fr->sequence) /* all or nothing: the frames written before this one go too */
        frames_remove(out_path, stats_path, first, f);
    if (rc && fr->given)
        vx_wrap(e, "frame %d", f);
    if (used != DYN_REBAKE)
        dyn_free(&d);
    return rc;
}
