/* The camera cones' ends (tracer/render/cone_camera_ends.h, issue 15) are exact:
 *  - brute force over the shipped scenes' grids (a resolution that is not a power of two, 256^3)
 *    and many pinhole cameras (the scene's; random ones around the grid and inside its box, looking
 *    anywhere; far away, where the cones are wide and their proof levels coarse; wide and narrow
 *    fields of view; small images, where a pixel's cone is many voxels wide): for every pixel, the
 *    cone marcher itself (render_cone_core.h, with an element that covers nothing, so every cone
 *    walks to its end and asks about every element it can) asks about exactly the same elements,
 *    the same bits of centre, radius, level and [t0, t1] in the same order, when its walk ends
 *    where the map says as when it walks to the grid's edge; a pixel the map empties asks about
 *    none;
 *  - the map is the same whatever the thread count, and a build keeps nothing of the one before; and
 *    the same when every level's blocks are looked at (the build looks only at the levels that the
 *    grid's depths allow);
 *  - the map ends something: on the scenes' own cameras most of the cones that ask about nothing
 *    are not walked at all;
 *  - render_image gives heitz-neyret the same image, word for word, with and without the ends
 *    (render_options.pixel_bounds; bunny and trees), and counts the map's bytes when it has one. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cone_camera_ends.h"
#include "grid_scene.h"
#include "grid_walk.h"
#include "render_toggle.h"
#include "rng.h"
#include "unit.h"

/* The elements a walk asks about: how many, and a hash of their queries' bits in order. */
typedef struct {
    int count;
    uint64_t hash;
    float last_t; /* the last one's far end (q->t1) */
} element_log;

static element_log *current_log;

static void log_bits(element_log *L, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t k = 0; k < n; k++)
        L->hash = (L->hash ^ b[k]) * 1099511628211ULL;
}

/* An element that covers nothing (so the walk goes on to its end), logging what it is asked. */
static void log_element(const vx_query *q, vx_answer *a)
{
    element_log *L = current_log;
    L->count++;
    log_bits(L, &q->position, sizeof q->position);
    log_bits(L, &q->footprint, sizeof q->footprint);
    log_bits(L, &q->level, sizeof q->level);
    log_bits(L, &q->t0, sizeof q->t0);
    log_bits(L, &q->t1, sizeof q->t1);
    L->last_t = q->t1;
    memset(a, 0, sizeof *a);
}

#define CONE_ELEMENT(x, q, a) ((void)(x), log_element(q, a))
#define CONE_CAMERA_END(x, t_end) vx_fminf((t_end), (x)->camera_end)
#include "render_cone_core.h"

typedef struct {
    int cones, differ, emptied, asks_nothing, emptied_asking; /* the last: a bug, counted apart */
    double cut, walk;                                          /* t cut past the last element, t walked */
} ends_tally;

/* Whether two built maps are the same: both without a map, or both with the same bits. */
static int maps_equal(const pixel_bounds *a, const pixel_bounds *b)
{
    size_t bytes = (size_t)a->map_w * (size_t)a->map_h * sizeof(float);
    if (pixel_bounds_active(a) != pixel_bounds_active(b))
        return 0;
    return !pixel_bounds_active(a) ||
           (memcmp(a->near_t, b->near_t, bytes) == 0 && memcmp(a->far_t, b->far_t, bytes) == 0);
}

/* Every pixel of a w x h image of camera cam over grid g (with its dilated bitmaps d): the walk to
 * the map's end against the walk to the grid's edge. */
static void camera_checks(const char *label, const voxel_grid *g, const dilated_grid *d, const camera *cam, int w,
                          int h, ends_tally *T)
{
    char name[300];
    pixel_bounds b, b1, every;
    if (pixel_bounds_alloc(&b, w, h, CONE_ENDS_TILE_SHIFT, 2) || pixel_bounds_alloc(&b1, w, h, CONE_ENDS_TILE_SHIFT, 3) ||
        pixel_bounds_alloc(&every, w, h, CONE_ENDS_TILE_SHIFT, 2)) {
        printf("not ok %s: out of memory\n", label);
        unit_failures++;
        return;
    }
    float spread = camera_pixel_spread(cam, h);
    /* b is built for another camera first: a build must keep nothing of the one before. */
    camera other = *cam;
    other.position = v3_add(cam->position, v3_scale(cam->forward, -0.5f * v3_length(cam->position) - 1.0f));
    cone_camera_ends_build(&b, g, &other, spread, 2);
    cone_camera_ends_build(&b, g, cam, spread, 2);
    cone_camera_ends_build(&b1, g, cam, spread, 1);
    cone_camera_ends_build_every_level(&every, g, cam, spread, 2);
    snprintf(name, sizeof name, "%s: the map is the same as with every level's blocks looked at", label);
    CHECK(name, maps_equal(&b, &every));
    snprintf(name, sizeof name, "%s: the map is the same with 1 and 2 threads, and after a build for another camera",
             label);
    CHECK(name, maps_equal(&b, &b1));
    cone_ctx x;
    memset(&x, 0, sizeof x);
    x.g = g;
    x.skip = d;
    int differ = 0;
    for (int py = 0; py < h; py++)
        for (int px = 0; px < w; px++) {
            vec3 org, dir;
            camera_ray(cam, w, h, (float)px + 0.5f, (float)py + 0.5f, 0.5f, 0.5f, 0, &org, &dir);
            element_log whole = {0, 1469598103934665603ULL, 0.0f}, ended = whole;
            x.camera_end = INFINITY;
            current_log = &whole;
            cone_trace(&x, org, dir, spread, 0.0f, 1.0f, cam->forward, v3(0.0f, 0.0f, 0.0f));
            float end = cone_camera_end(&b, cam->forward, px, py, dir);
            x.camera_end = end;
            current_log = &ended;
            cone_trace(&x, org, dir, spread, 0.0f, 1.0f, cam->forward, v3(0.0f, 0.0f, 0.0f));
            int same = whole.count == ended.count && whole.hash == ended.hash;
            if (!same && differ < 5)
                printf("# %s: pixel (%d %d) asks about %d elements to the grid's edge, %d to its end %g\n", label, px,
                       py, whole.count, ended.count, end);
            differ += !same;
            T->cones++;
            T->asks_nothing += whole.count == 0;
            T->emptied += end == -INFINITY;
            T->emptied_asking += end == -INFINITY && whole.count > 0;
            float t0, t1;
            cone c = {org, dir, 0.0f, camera_cone_spread(spread, v3_dot(dir, cam->forward)), 0.0f, 1.0f, 1.0f,
                      0.125f * g->voxel_size};
            if (whole.count > 0 && end < INFINITY && cone_clip_reach(g, &c, &t0, &t1) && t1 > whole.last_t) {
                T->cut += vx_fmaxf(t1 - vx_fmaxf(end, whole.last_t), 0.0f);
                T->walk += t1 - whole.last_t;
            }
        }
    snprintf(name, sizeof name, "%s: every cone asks about the same elements with its end as without (%d differ)",
             label, differ);
    CHECK(name, differ == 0);
    T->differ += differ;
    pixel_bounds_free(&b);
    pixel_bounds_free(&b1);
    pixel_bounds_free(&every);
}

/* A pinhole camera at p looking along f (camera_face's frame). */
static camera look(const camera *base, vec3 p, vec3 f, float fov_deg)
{
    camera c = *base;
    c.position = p;
    camera_face(&c, v3_normalize(f));
    c.tan_half_fov_y = tanf(0.5f * fov_deg * 3.14159265f / 180.0f);
    c.aperture_radius = 0.0f;
    return c;
}

static void scene_checks(const char *path, int res, int cameras, int w, int h)
{
    scene s;
    vx_err e;
    voxel_grid g;
    dilated_grid d;
    if (scene_load(path, &s, &e) || grid_build_scene(&g, &s, res, NULL, NULL, &e) || dilated_build(&d, &g)) {
        printf("not ok %s %d^3: %s\n", path, res, e.msg);
        unit_failures++;
        return;
    }
    char label[300];
    ends_tally own = {0}, all = {0};
    snprintf(label, sizeof label, "%s %d^3, its camera, %dx%d", path, res, w, h);
    camera_checks(label, &g, &d, &s.camera, w, h, &own);
    snprintf(label, sizeof label,
             "%s %d^3, its camera: %d of %d cones ask about nothing, the map empties %d (%d asking: none may); "
             "%.0f %% of the walk past the last elements is cut",
             path, res, own.asks_nothing, own.cones, own.emptied, own.emptied_asking,
             own.walk > 0.0 ? 100.0 * own.cut / own.walk : 0.0);
    CHECK(label, own.emptied_asking == 0 && own.asks_nothing > 0 && own.emptied * 3 > own.asks_nothing);
    rng r = rng_seed(17, (uint64_t)res);
    vec3 lo = v3((float)g.origin_d[0], (float)g.origin_d[1], (float)g.origin_d[2]);
    float side = (float)(g.n * g.voxel_size_d);
    vec3 centre = v3_add(lo, v3(0.5f * side, 0.5f * side, 0.5f * side));
    for (int k = 0; k < cameras; k++) {
        camera c;
        int cw = w, ch = h;
        if (k % 4 == 0) { /* around the grid, looking at its centre, a wide or a narrow view */
            vec3 p = v3_add(centre, v3_scale(random_unit(&r), side * (0.9f + 1.5f * rng_float(&r))));
            c = look(&s.camera, p, v3_sub(centre, p), k % 8 ? 90.0f : 20.0f);
        } else if (k % 4 == 1) { /* inside the grid's box, looking anywhere */
            vec3 p = v3_add(lo, v3(side * rng_float(&r), side * rng_float(&r), side * rng_float(&r)));
            c = look(&s.camera, p, random_unit(&r), 30.0f + 80.0f * rng_float(&r));
        } else if (k % 4 == 2) { /* far away: wide cones, coarse proof levels */
            vec3 p = v3_add(centre, v3_scale(random_unit(&r), side * (4.0f + 20.0f * rng_float(&r))));
            c = look(&s.camera, p, v3_sub(centre, p), 40.0f);
        } else { /* a small image: each pixel's cone many voxels wide */
            vec3 p = v3_add(centre, v3_scale(random_unit(&r), side * (1.0f + rng_float(&r))));
            c = look(&s.camera, p, v3_add(v3_sub(centre, p), v3_scale(random_unit(&r), 0.3f * side)), 60.0f);
            cw = 12;
            ch = 9;
        }
        snprintf(label, sizeof label, "%s %d^3, camera %d, %dx%d", path, res, k, cw, ch);
        camera_checks(label, &g, &d, &c, cw, ch, &all);
    }
    printf("# %s %d^3, %d other cameras: %d cones, %d ask about nothing, the map empties %d; %.0f %% of the walk past "
           "the last elements is cut\n",
           path, res, cameras, all.cones, all.asks_nothing, all.emptied,
           all.walk > 0.0 ? 100.0 * all.cut / all.walk : 0.0);
    snprintf(label, sizeof label, "%s %d^3, %d other cameras: no cone the map empties asks about an element", path, res,
             cameras);
    CHECK(label, all.emptied_asking == 0);
    dilated_free(&d);
    grid_free(&g);
    scene_free(&s);
}

static void bounds_switch(render_options *o, int on) { o->pixel_bounds = on; }

/* render_image counts the map's bytes with the ends on, and none of it with them off. */
static void map_bytes_check(const char *path)
{
    scene s;
    vx_err e;
    const vx_model *m = model_find("heitz-neyret");
    bake_options bo = {.rays = 16, .seed = 1, .threads = 0, .progress = 0};
    bake_counts bc;
    double gs;
    voxel_grid g;
    void *rec = NULL;
    if (!m || scene_load(path, &s, &e) || bake_scene(&s, m, 32, &bo, &g, &rec, &bc, &gs, &e)) {
        printf("not ok %s: bake\n", path);
        unit_failures++;
        return;
    }
    size_t bytes[2] = {0, 0};
    for (int on = 0; on < 2; on++) {
        render_options o;
        render_default_options(&o);
        o.width = 40;
        o.height = 30;
        o.progress = 0;
        o.pixel_bounds = on;
        image img;
        render_counts c;
        if (render_image(&s, &g, m, rec, &o, &img, &c, &e) == 0) {
            bytes[on] = c.map_bytes;
            image_free(&img);
        }
    }
    char name[300];
    snprintf(name, sizeof name, "%s heitz-neyret: the ends' map counts in map_bytes (%zu bytes with, %zu without)",
             path, bytes[1], bytes[0]);
    CHECK(name, bytes[1] >= bytes[0] + 2 * 20 * 15 * sizeof(float));
    free(rec);
    grid_free(&g);
    scene_free(&s);
}

int main(void)
{
    scene_checks("scenes/bunny.json", 100, 16, 64, 40);
    scene_checks("scenes/trees.json", 64, 12, 48, 48);
    scene_checks("scenes/city.json", 96, 12, 64, 40);
    scene_checks("scenes/bunny.json", 256, 4, 40, 40);
    map_bytes_check("scenes/bunny.json");
    render_toggle_checks("scenes/bunny.json", "heitz-neyret", 48, bounds_switch, "the camera cones' ends");
    render_toggle_checks("scenes/trees.json", "heitz-neyret", 48, bounds_switch, "the camera cones' ends");
    return unit_exit();
}
