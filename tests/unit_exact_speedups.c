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
 * (--shadows voxel) against marched. Every model, baked once per case; each pair of images at the
 * three shapes and ray counts of render_toggle_compare, over its background. A speed-up that moved a
 * single ray's cells would change some pixel. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "render.h"
#include "scene.h"
#include "render_toggle.h"
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

/* Each switch but the threads' own runs on 3 threads, so that both images take the pool, its bands
 * and their tail. */
static void bounds_switch(render_options *o, int on)
{
    o->threads = 3;
    o->pixel_bounds = on;
}
static void clip_switch(render_options *o, int on)
{
    o->threads = 3;
    o->shadow_clip = on;
}
static void skip_switch(render_options *o, int on)
{
    o->threads = 3;
    o->empty_skip = on;
}

static const struct {
    render_switch set;
    const char *what;
    int per_voxel_only; /* a cone model has no per-voxel shadows to precompute */
} switches[] = {{bounds_switch, "the depth bounds", 0},
                {clip_switch, "the shadow rays' ends", 0},
                {skip_switch, "the empty-space skip", 0},
                {render_toggle_all_speedups, "all three", 0},
                {render_toggle_threads, "3 threads (off: 1)", 0},
                {render_toggle_voxel_shadows, "shadows precomputed per voxel", 1}};

/* Model m baked once on scene s, then every switch off and on (render_toggle_compare). */
static void case_checks(const char *label, const scene *s, const vx_model *m)
{
    char name[300];
    snprintf(name, sizeof name, "%s %s", label, m->name);
    voxel_grid g;
    void *rec;
    if (render_toggle_bake(name, s, m, 48, &g, &rec))
        return;
    for (size_t k = 0; k < sizeof switches / sizeof switches[0]; k++)
        if (!switches[k].per_voxel_only || m->voxel)
            render_toggle_compare(name, s, &g, m, rec, switches[k].set, switches[k].what);
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
        render_toggle_background(&s);
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
