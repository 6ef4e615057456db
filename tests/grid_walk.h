/* Test helpers for the exact ray-interval optimisations (pixel_skip.h, pixel_bounds.h,
 * shadow_clip.h, cone_camera_ends.h): random directions, cameras facing them, a DDA walk recorded
 * cell by cell, compared bit for bit, and a brute-force check of an interval against every
 * non-empty voxel's box. */
#ifndef VX_TEST_GRID_WALK_H
#define VX_TEST_GRID_WALK_H

#include <math.h>
#include <string.h>

#include "camera.h"
#include "grid_traverse_core.h"
#include "rng.h"
#include "vec_d.h"

#define WALK_MAX_CELLS 4096

/* A random unit vector (rejection from the cube). */
static inline vec3 random_unit(rng *r)
{
    for (;;) {
        vec3 v = v3(2.0f * rng_float(r) - 1.0f, 2.0f * rng_float(r) - 1.0f, 2.0f * rng_float(r) - 1.0f);
        float l = v3_length(v);
        if (l > 0.1f && l <= 1.0f)
            return v3_scale(v, 1.0f / l);
    }
}

/* Turns camera c to face along unit vector f (its up the world's y, or x when f is near y). */
static inline void camera_face(camera *c, vec3 f)
{
    c->forward = f;
    vec3 helper = fabsf(f.y) < 0.9f ? v3(0.0f, 1.0f, 0.0f) : v3(1.0f, 0.0f, 0.0f);
    c->right = v3_normalize(v3_cross(f, helper));
    c->up = v3_cross(c->right, f);
}

typedef struct {
    int64_t index;
    float t0, t1;
} walk_cell;

/* The cells a level-0 walk of o + t d over [t_min, t_max] reports, into out; returns their count. */
static inline int walk_cells(const voxel_grid *g, vec3 o, vec3 d, float t_min, float t_max, walk_cell *out)
{
    grid_iter it;
    grid_hit h;
    int n = 0;
    if (!gt_iter_init(&it, g, 0, o, d, t_min, t_max))
        return 0;
    while (n < WALK_MAX_CELLS && gt_iter_next(&it, &h)) {
        out[n].index = h.index;
        out[n].t0 = h.t0;
        out[n].t1 = h.t1;
        n++;
    }
    return n;
}

/* Whether two walks report the same cells with the same [t0, t1] bits. */
static inline int walks_equal(const walk_cell *a, int na, const walk_cell *b, int nb)
{
    if (na != nb)
        return 0;
    for (int c = 0; c < na; c++)
        if (a[c].index != b[c].index || memcmp(&a[c].t0, &b[c].t0, sizeof(float)) != 0 ||
            memcmp(&a[c].t1, &b[c].t1, sizeof(float)) != 0)
            return 0;
    return 1;
}

/* Brute force, independent of the DDA: the number of non-empty voxels whose closed box the ray
 * o + t d (t >= t_start) touches outside [lo, hi] (slab test in double). */
static inline int voxels_outside(const voxel_grid *g, vec3 o, vec3 d, double t_start, double lo, double hi)
{
    const grid_level *L = &g->level[0];
    const double od[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
    int outside = 0;
    for (size_t i = 0; i < L->count; i++) {
        uint32_t pc = L->coords[i];
        const int c[3] = {(int)(pc >> 20), (int)((pc >> 10) & 1023u), (int)(pc & 1023u)};
        double bl[3], bh[3], a, b;
        for (int k = 0; k < 3; k++) {
            bl[k] = g->origin_d[k] + c[k] * g->voxel_size_d;
            bh[k] = g->origin_d[k] + (c[k] + 1) * g->voxel_size_d;
        }
        if (vx_ray_box(od, dd, bl, bh, t_start, &a, &b) && (a < lo || b > hi))
            outside++;
    }
    return outside;
}

#endif
