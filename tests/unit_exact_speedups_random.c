/* The render's exact speed-ups (issue 15) leave the image unchanged, word for word, from views nobody
 * chose: unit_exact_speedups.c stresses city from four views picked for their hard cases; here each
 * shipped scene is seen from cameras and lit by lights drawn at random (a fixed seed, so a failure
 * comes back): a camera anywhere from inside the grid to three times its size away, looking at a
 * point near the grid's centre with a field of view of 15 to 100 degrees, any roll; a directional
 * light from any direction, or a point light inside or around the grid. Every model is baked once
 * per scene; each view renders with the depth bounds, the shadow rays' ends and the empty-space skip
 * all off, then all on; on 1 thread, then 3; and, for the per-voxel models, with its shadows marched,
 * then precomputed per voxel (--shadows voxel, whose image is march's). Each pair goes through
 * render_toggle_compare (three shapes and ray counts). A speed-up that moved a single ray's cells
 * from some view would change a pixel. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "render.h"
#include "render_toggle.h"
#include "scene.h"
#include "unit.h"

#define VIEWS_PER_SCENE 12
#define BAKE_RES 40

/* xorshift64*: the views' numbers, the same on every machine. */
static double next_unit(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * UINT64_C(2685821657736338717)) >> 11) * (1.0 / 9007199254740992.0);
}

static vec3 random_direction(uint64_t *s)
{
    for (;;) {
        vec3 v = v3((float)(2.0 * next_unit(s) - 1.0), (float)(2.0 * next_unit(s) - 1.0),
                    (float)(2.0 * next_unit(s) - 1.0));
        float l2 = v3_dot(v, v);
        if (l2 > 1e-4f && l2 <= 1.0f)
            return v3_scale(v, 1.0f / sqrtf(l2));
    }
}

/* A camera drawn as the top of this file says, its frame orthonormal as scene.c builds it (right =
 * forward x up); the roll comes from the random up. */
static camera random_camera(uint64_t *s, vec3 centre, float size)
{
    camera c;
    memset(&c, 0, sizeof c);
    for (;;) {
        /* from inside the grid (a tenth of its size from the centre) to three times its size away */
        float dist = size * (float)(0.1 + 2.9 * next_unit(s));
        c.position = v3_madd(centre, random_direction(s), dist);
        vec3 at = v3_madd(centre, random_direction(s), 0.25f * size * (float)next_unit(s));
        vec3 fwd = v3_sub(at, c.position);
        if (v3_length(fwd) < 1e-3f * size)
            continue;
        c.forward = v3_normalize(fwd);
        vec3 right = v3_cross(c.forward, random_direction(s));
        if (v3_length(right) < 0.1f)
            continue;
        c.right = v3_normalize(right);
        c.up = v3_cross(c.right, c.forward);
        break;
    }
    c.tan_half_fov_y = tanf((float)(15.0 + 85.0 * next_unit(s)) * 3.14159265f / 360.0f);
    c.focus_distance = 1.0f;
    return c;
}

static void random_light(uint64_t *s, vec3 centre, float size, light *L)
{
    if (next_unit(s) < 0.7) {
        L->type = LIGHT_DIRECTIONAL;
        L->direction = random_direction(s);
    } else {
        L->type = LIGHT_POINT;
        L->position = v3_madd(centre, random_direction(s), size * (float)(0.2 + 1.3 * next_unit(s)));
        L->radiance = v3(4.0f * size * size, 4.0f * size * size, 4.0f * size * size);
    }
}

/* Whether the view shows any voxel: a pixel of a small image that is not the background (a test of
 * views that all miss would compare backgrounds only). */
static int view_shows_voxels(const scene *s, const voxel_grid *g, const vx_model *m, const void *rec)
{
    render_options o;
    render_default_options(&o);
    o.width = 24;
    o.height = 16;
    o.spp = 1;
    o.progress = 0;
    image img;
    render_counts c;
    vx_err e;
    if (render_image(s, g, m, rec, &o, &img, &c, &e))
        return 0;
    int shows = 0;
    for (int i = 0; i < o.width * o.height && !shows; i++)
        shows = img.data[3 * i] != s->background.x || img.data[3 * i + 1] != s->background.y ||
                img.data[3 * i + 2] != s->background.z;
    image_free(&img);
    return shows;
}

static void scene_checks(const char *path, uint64_t seed)
{
    scene s;
    vx_err e;
    if (scene_load(path, &s, &e)) {
        printf("not ok %s: %s\n", path, e.msg);
        unit_failures++;
        return;
    }
    render_toggle_background(&s);
    for (const vx_model *const *m = model_all(); *m; m++) {
        char label[400];
        snprintf(label, sizeof label, "%s %s %d^3", path, (*m)->name, BAKE_RES);
        voxel_grid g;
        void *rec;
        if (render_toggle_bake(label, &s, *m, BAKE_RES, &g, &rec))
            continue;
        float size = (float)(g.n * g.voxel_size_d);
        vec3 centre = v3_add(g.origin, v3(0.5f * size, 0.5f * size, 0.5f * size));
        uint64_t rs = seed; /* the same views for every model of the scene */
        int shown = 0;
        for (int v = 0; v < VIEWS_PER_SCENE; v++) {
            s.camera = random_camera(&rs, centre, size);
            random_light(&rs, centre, size, &s.lights[0]);
            char name[500];
            snprintf(name, sizeof name, "%s, random view %d (camera %.3g %.3g %.3g, light %s)", label, v,
                     s.camera.position.x, s.camera.position.y, s.camera.position.z,
                     s.lights[0].type == LIGHT_DIRECTIONAL ? "directional" : "point");
            render_toggle_compare(name, &s, &g, *m, rec, render_toggle_all_speedups, "every exact speed-up");
            render_toggle_compare(name, &s, &g, *m, rec, render_toggle_threads, "3 threads (off: 1)");
            if ((*m)->voxel)
                render_toggle_compare(name, &s, &g, *m, rec, render_toggle_voxel_shadows, "shadows precomputed per voxel");
            shown += view_shows_voxels(&s, &g, *m, rec);
        }
        char name[500];
        snprintf(name, sizeof name, "%s: at least half the random views show voxels (%d of %d)", label, shown,
                 VIEWS_PER_SCENE);
        CHECK(name, 2 * shown >= VIEWS_PER_SCENE);
        free(rec);
        grid_free(&g);
    }
    scene_free(&s);
}

int main(void)
{
    const char *scenes[] = {"scenes/bunny.json", "scenes/trees.json", "scenes/city.json", "scenes/spheres.json",
                            "scenes/heightfield.json"};
    for (size_t k = 0; k < sizeof scenes / sizeof scenes[0]; k++)
        scene_checks(scenes[k], UINT64_C(0x9E3779B97F4A7C15) ^ (uint64_t)(k + 1) * UINT64_C(0xBF58476D1CE4E5B9));
    return unit_exit();
}
