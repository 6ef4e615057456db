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

static inline void render_toggle_checks(const char *path, const char *model, int res, render_switch set,
                                        const char *what)
{
    scene s;
    vx_err e;
    const vx_model *m = model_find(model);
    if (!m || scene_load(path, &s, &e)) {
        printf("not ok render %s %s\n", path, model);
        unit_failures++;
        return;
    }
    /* A background whose mean over 5 equal rays is not itself in float (0.9504637 and 0.42332646
     * come back an ulp off): a pixel an optimisation fills without marching (pixel_bounds.h's empty
     * pixels) must sum its rays' background as the march does. */
    s.background = v3(0.9504637f, 0.42332646f, 0.027559113f);
    bake_options bo = {.rays = 16, .seed = 1, .threads = 0, .progress = 0};
    bake_counts bc;
    double gs;
    voxel_grid g;
    void *rec = NULL;
    render_counts c;
    int ok = bake_scene(&s, m, res, &bo, &g, &rec, &bc, &gs, &e) == 0;
    const int spps[] = {4, 1, 5}, widths[] = {98, 96, 50};
    for (int v = 0; ok && v < 3; v++) {
        image img[2];
        int w = widths[v], h = 40;
        for (int k = 0; ok && k < 2; k++) {
            render_options o;
            render_default_options(&o);
            o.width = w;
            o.height = h;
            o.spp = spps[v];
            o.progress = 0;
            set(&o, k);
            ok = render_image(&s, &g, m, rec, &o, &img[k], &c, &e) == 0;
            if (!ok && k == 1)
                image_free(&img[0]);
        }
        char name[300];
        snprintf(name, sizeof name, "%s %s %d^3, %dx%d, %d spp: the image with %s equals the image without, word for word",
                 path, model, res, w, h, spps[v], what);
        CHECK(name, ok && memcmp(img[0].data, img[1].data, (size_t)w * h * 3 * sizeof(float)) == 0);
        if (ok) {
            image_free(&img[0]);
            image_free(&img[1]);
        }
    }
    if (ok) {
        free(rec);
        grid_free(&g);
    }
    scene_free(&s);
}

#endif
