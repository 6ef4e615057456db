/* The render's exact speed-ups (issue 15) leave the image unchanged, word for word, on the cases that
 * stress them most, beyond the shipped scenes' own views (which tests/render_toggle.h covers on bunny
 * and trees): city's box buildings, whose faces lie on the grid's planes, under
 *  - its own camera and light;
 *  - a light straight down the y axis (shadow rays along the lattice's columns: the shadow-clip map's
 *    frame and the DDA's ties between axes) and a camera looking straight down on the blocks;
 *  - a camera at street level, inside the grid between the buildings (no depth-bounds map can be
 *    made: the distance-field skip's path), looking along the x axis;
 *  - a point light (no opacity memo, no shadow-clip map: the per-ray path).
 * Each speed-up is switched off and on in turn, and all three together: the depth bounds and slabs
 * (pixel_bounds.h, and the camera cones' ends), the shadow rays' and light cones' ends
 * (shadow_clip.h), the distance-field skip (pixel_skip.h); and 1 against 3 threads (the pool, the
 * bands and their 2-row tail); and, for the per-voxel models, the shadows precomputed per voxel
 * (--shadows voxel) against marched. Every model, baked once per case. A speed-up that moved a
 * single ray's cells would change some pixel. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "render.h"
#include "scene.h"
#include "shadow_maps_core.h"
#include "unit.h"

/* A pinhole camera at pos looking at `at` (scene.c's frame: forward, right = forward x up, up). */
static camera look(vec3 pos, vec3 at, vec3 up, float fov_deg)
{
    camera c;
    memset(&c, 0, sizeof c);
    c.position = pos;
    c.forward = v3_normalize(v3_sub(at, pos));
    c.right = v3_normalize(v3_cross(c.forward, up));
    c.up = v3_cross(c.right, c.forward);
    c.tan_half_fov_y = tanf(fov_deg * 3.14159265f / 360.0f);
    c.focus_distance = v3_length(v3_sub(at, pos));
    return c;
}

enum { SW_BOUNDS, SW_CLIP, SW_SKIP, SW_ALL, SW_THREADS, SW_VOXEL_SHADOWS, SWITCHES };
static const char *const switch_names[SWITCHES] = {"the depth bounds", "the shadow rays' ends", "the empty-space skip",
                                                   "all three", "3 threads (off: 1)", "shadows precomputed per voxel"};

static void set_switch(render_options *o, int sw, int on)
{
    o->threads = 3;
    switch (sw) {
    case SW_BOUNDS: o->pixel_bounds = on; break;
    case SW_CLIP: o->shadow_clip = on; break;
    case SW_SKIP: o->empty_skip = on; break;
    case SW_ALL: o->pixel_bounds = o->shadow_clip = o->empty_skip = on; break;
    case SW_THREADS: o->threads = on ? 3 : 1; break;
    case SW_VOXEL_SHADOWS: o->shadow_method = on ? SHADOW_VOXEL : SHADOW_MARCH; break;
    }
}

/* Every switch off and on for model m on scene s: the two images equal, word for word. */
static void case_checks(const char *label, const scene *s, const vx_model *m)
{
    bake_options bo = {.rays = 16, .seed = 1, .threads = 0, .progress = 0};
    bake_counts bc;
    double gs;
    voxel_grid g;
    void *rec = NULL;
    vx_err e;
    char name[400];
    if (bake_scene(s, m, 48, &bo, &g, &rec, &bc, &gs, &e)) {
        snprintf(name, sizeof name, "%s %s: baked (%s)", label, m->name, e.msg);
        CHECK(name, 0);
        return;
    }
    int per_voxel = m->voxel != NULL;
    for (int sw = 0; sw < SWITCHES; sw++) {
        if (sw == SW_VOXEL_SHADOWS && !per_voxel)
            continue; /* a cone model has no per-voxel shadows to precompute */
        image img[2];
        int ok = 1, made = 0;
        render_counts c;
        for (int k = 0; k < 2 && ok; k++) {
            render_options o;
            render_default_options(&o);
            o.width = 98; /* a row ending in a span of two (voxel_render_span) */
            o.height = 40;
            o.spp = 4;
            o.progress = 0;
            set_switch(&o, sw, k);
            ok = render_image(s, &g, m, rec, &o, &img[k], &c, &e) == 0;
            made += ok;
        }
        snprintf(name, sizeof name, "%s %s: the image with %s equals the image without, word for word", label,
                 m->name, switch_names[sw]);
        CHECK(name, ok && memcmp(img[0].data, img[1].data, (size_t)98 * 40 * 3 * sizeof(float)) == 0);
        for (int k = 0; k < made; k++)
            image_free(&img[k]);
    }
    free(rec);
    grid_free(&g);
}

int main(void)
{
    vx_err e;
    const int cases = 4;
    const char *labels[] = {"city, its own view", "city, light and camera straight down the y axis",
                            "city, camera at street level inside the grid", "city, a point light"};
    for (int c = 0; c < cases; c++) {
        scene s;
        if (scene_load("scenes/city.json", &s, &e)) {
            printf("not ok scenes/city.json: %s\n", e.msg);
            return 1;
        }
        if (c == 1) {
            s.lights[0].direction = v3(0.0f, 1.0f, 0.0f);
            s.camera = look(v3(0.0f, 20.0f, 0.0f), v3(0.0f, 0.0f, 0.0f), v3(0.0f, 0.0f, -1.0f), 40.0f);
        } else if (c == 2) {
            s.camera = look(v3(0.31f, 0.45f, 0.22f), v3(5.0f, 0.45f, 0.22f), v3(0.0f, 1.0f, 0.0f), 70.0f);
        } else if (c == 3) {
            s.lights[0].type = LIGHT_POINT;
            s.lights[0].position = v3(2.0f, 6.0f, 2.0f);
            s.lights[0].radiance = v3(20.0f, 20.0f, 20.0f);
        }
        for (const vx_model *const *m = model_all(); *m; m++)
            case_checks(labels[c], &s, *m);
        scene_free(&s);
    }
    return unit_exit();
}
