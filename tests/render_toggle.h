/* Test helper: render_image with an exact optimisation off and on (a render_options switch) must give
 * the same image, word for word: bunny-like scenes baked small, at 4 spp on a 98-wide image (a row
 * ending in a span of two, voxel_render_span), 1 spp and 5 spp (each pixel's rays alone), over an
 * awkward background (below). */
#ifndef VX_TEST_RENDER_TOGGLE_H
#define VX_TEST_RENDER_TOGGLE_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "render.h"
#include "unit.h"

typedef void (*render_switch)(render_options *o, int on);

/* Switches that more than one test turns. All three exact speed-ups together (the depth bounds and
 * slabs, the shadow rays' and light cones' ends, the empty-space skip), on 3 threads so that both
 * images take the pool, its bands and their tail. */
static inline void render_toggle_all_speedups(render_options *o, int on)
{
    o->threads = 3;
    o->pixel_bounds = o->shadow_clip = o->empty_skip = on;
}
/* 3 threads (on) against 1. */
static inline void render_toggle_threads(render_options *o, int on) { o->threads = on ? 3 : 1; }
/* The per-voxel models' shadows precomputed per voxel (on) against marched, on 3 threads. */
static inline void render_toggle_voxel_shadows(render_options *o, int on)
{
    o->threads = 3;
    o->shadow_method = on ? SHADOW_VOXEL : SHADOW_MARCH;
}

/* A background whose mean over 5 equal rays is not itself in float (0.9504637 and 0.42332646 come
 * back an ulp off): a pixel an optimisation fills without marching (pixel_bounds.h's empty pixels)
 * must sum its rays' background as the march does. Set before baking (it is not in the records). */
static inline void render_toggle_background(scene *s) { s->background = v3(0.9504637f, 0.42332646f, 0.027559113f); }

/* Model m's records rec on grid g of scene s rendered with `set` off and on, at 4 spp on a 98-wide
 * image, 1 spp and 5 spp: each pair equal, word for word. Checks are named "LABEL, WxH, N spp: ...". */
static inline void render_toggle_compare(const char *label, const scene *s, const voxel_grid *g, const vx_model *m,
                                         const void *rec, render_switch set, const char *what)
{
    const int spps[] = {4, 1, 5}, widths[] = {98, 96, 50};
    for (int v = 0; v < 3; v++) {
        image img[2];
        int w = widths[v], h = 40, ok = 1, made = 0;
        render_counts c;
        vx_err e;
        for (int k = 0; k < 2 && ok; k++) {
            render_options o;
            render_default_options(&o);
            o.width = w;
            o.height = h;
            o.spp = spps[v];
            o.progress = 0;
            set(&o, k);
            ok = render_image(s, g, m, rec, &o, &img[k], &c, &e) == 0;
            made += ok;
        }
        char name[400];
        snprintf(name, sizeof name, "%s, %dx%d, %d spp: the image with %s equals the image without, word for word",
                 label, w, h, spps[v], what);
        CHECK(name, ok && memcmp(img[0].data, img[1].data, (size_t)w * h * 3 * sizeof(float)) == 0);
        for (int k = 0; k < made; k++)
            image_free(&img[k]);
    }
}

/* Model m's records for scene s at res^3, baked small (16 rays a voxel): 0, or -1 after a failed
 * check named LABEL. */
static inline int render_toggle_bake(const char *label, const scene *s, const vx_model *m, int res, voxel_grid *g,
                                     void **rec)
{
    bake_options bo = {.rays = 16, .seed = 1, .threads = 0, .progress = 0};
    bake_counts bc;
    double gs;
    vx_err e;
    *rec = NULL;
    if (bake_scene(s, m, res, &bo, g, rec, &bc, &gs, &e) == 0)
        return 0;
    printf("not ok %s: baked (%s)\n", label, e.msg);
    unit_failures++;
    return -1;
}

/* Scene `path` (its background render_toggle_background's) baked small at res^3 for `model`, then
 * render_toggle_compare. */
static inline void render_toggle_checks(const char *path, const char *model, int res, render_switch set,
                                        const char *what)
{
    scene s;
    vx_err e;
    char label[300];
    snprintf(label, sizeof label, "%s %s %d^3", path, model, res);
    const vx_model *m = model_find(model);
    if (!m || scene_load(path, &s, &e)) {
        printf("not ok render %s %s\n", path, model);
        unit_failures++;
        return;
    }
    render_toggle_background(&s);
    voxel_grid g;
    void *rec;
    if (render_toggle_bake(label, &s, m, res, &g, &rec) == 0) {
        render_toggle_compare(label, &s, &g, m, rec, set, what);
        free(rec);
        grid_free(&g);
    }
    scene_free(&s);
}

#endif
