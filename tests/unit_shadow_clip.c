/* The shadow rays' ends toward a directional light (tracer/render/shadow_clip.h, issue 15) are exact:
 *  - brute force over the shipped scenes' grids (several resolutions, one not a power of two) and
 *    several light directions (the scene's, along an axis, along a diagonal, nearly along an axis,
 *    random): for shadow rays from non-empty voxels' centres (as the marcher casts them, starting
 *    1.5 voxels out) and from random points, the walk that ends at shadow_clip_end reports exactly
 *    the cells, indices and [t0, t1] bits of the walk to the grid's edge, and no non-empty voxel's
 *    box touches the ray beyond the end (slab tests against every voxel, not the DDA);
 *  - the ends end: rays from voxels that nothing shadows stop within a few voxels of their start
 *    (under 5 on average, and under half the way to the grid's edge);
 *  - a direction the map was not built for leaves the ray's end alone;
 *  - render_image gives the same image, word for word, with and without the ends (binary, alpha,
 *    vicini and vmesh, bunny and trees, shadows declared);
 *  - the light cones' maps (MIP levels 1 to 3, each cell grown to its 3x3x3 neighbourhood, with the
 *    cones' rounding slack): along light cones of each level's width from non-empty voxels and from
 *    random points, every element centre past the end, computed in float as the marcher computes it
 *    and sampled every tenth of a cell, has an empty neighbourhood by the marcher's own test
 *    (cone_neighbourhood_empty on the sparse grid), and the ends come before the grid's edge; and
 *    heitz-neyret's images are the same with and without them (bunny and trees). */
#include <stdio.h>
#include <stdlib.h>

#include "grid_scene.h"
#include "grid_walk.h"
#include "render_toggle.h"
#include "rng.h"
#include "shadow_clip.h"
#include "unit.h"

/* The cone marcher's own tests (its element level and neighbourhood test); no element is called. */
#define CONE_ELEMENT(x, q, a) ((void)(x), (void)(q), (void)(a))
#include "render_cone_core.h"

typedef struct {
    int rays, differ, beyond; /* walks compared, walks that differ, voxels touched past the end */
    int free_rays;            /* rays from voxel centres that meet nothing */
    double free_length;       /* their walks' length (end - start) in voxels, summed */
    double free_edge;         /* their length to the grid's edge, summed */
} clip_tally;

/* One shadow ray p + t dir from t_min: the clipped walk against the whole one, and the voxels. */
static void check_ray(const voxel_grid *g, const shadow_clip *c, vec3 p, vec3 dir, float t_min, int from_voxel,
                      clip_tally *t)
{
    static walk_cell full[WALK_MAX_CELLS], part[WALK_MAX_CELLS];
    float end = shadow_clip_end(c, p, dir, INFINITY);
    int nf = walk_cells(g, p, dir, t_min, INFINITY, full), np = walk_cells(g, p, dir, t_min, end, part);
    int same = walks_equal(full, nf, part, np);
    if (!same && t->differ < 5)
        printf("# differs: p (%g %g %g) dir (%g %g %g), end %g: %d cells to the edge, %d to the end\n", p.x, p.y, p.z,
               dir.x, dir.y, dir.z, end, nf, np);
    t->differ += !same;
    t->beyond += voxels_outside(g, p, dir, t_min, -INFINITY, end);
    t->rays++;
    if (from_voxel && nf == 0) {
        /* Where the ray leaves the grid's box (a slab test). */
        double exit = INFINITY;
        const double o[3] = {p.x, p.y, p.z}, d[3] = {dir.x, dir.y, dir.z};
        for (int a = 0; a < 3; a++)
            if (d[a] != 0.0) {
                double plane = g->origin_d[a] + (d[a] > 0.0 ? g->n * g->voxel_size_d : 0.0);
                double ta = (plane - o[a]) / d[a];
                exit = ta < exit ? ta : exit;
            }
        t->free_rays++;
        t->free_length += (end > t_min ? end - t_min : 0.0) / g->voxel_size;
        t->free_edge += (exit - t_min) / g->voxel_size;
    }
}

static void grid_checks(const char *label, const voxel_grid *g, vec3 dir, uint64_t seed)
{
    shadow_clip c;
    char name[300];
    if (shadow_clip_build(&c, g, dir)) {
        printf("not ok %s: out of memory\n", label);
        unit_failures++;
        return;
    }
    rng r = rng_seed(seed, 0);
    clip_tally t = {0};
    const grid_level *L = &g->level[0];
    float t_min = 1.5f * g->voxel_size; /* the marcher's shadow_skip */
    /* From voxel centres (every one on small grids, a sample on large ones), then random points. */
    size_t step = L->count / 400 + 1;
    for (size_t i = 0; i < L->count; i += step) {
        uint32_t pc = L->coords[i];
        vec3 lo, hi;
        grid_cell_corners(g, 0, (int)(pc >> 20), (int)((pc >> 10) & 1023u), (int)(pc & 1023u), &lo, &hi);
        check_ray(g, &c, v3_scale(v3_add(lo, hi), 0.5f), dir, t_min, 1, &t);
    }
    float size = g->n * g->voxel_size;
    for (int k = 0; k < 200; k++) {
        vec3 p = v3_add(g->origin, v3(size * rng_float(&r), size * rng_float(&r), size * rng_float(&r)));
        check_ray(g, &c, p, dir, 0.0f, 0, &t);
    }
    snprintf(name, sizeof name, "%s: walks to the end equal walks to the grid's edge, bit for bit (%d rays, %d differ)",
             label, t.rays, t.differ);
    CHECK(name, t.differ == 0);
    snprintf(name, sizeof name, "%s: no voxel's box touches a ray past its end (slab tests, %d touch)", label, t.beyond);
    CHECK(name, t.beyond == 0);
    double mean = t.free_rays ? t.free_length / t.free_rays : 0.0, edge = t.free_rays ? t.free_edge / t.free_rays : 0.0;
    snprintf(name, sizeof name,
             "%s: rays from %d unshadowed voxels end %.2f voxels past their start on average, the grid's edge %.1f "
             "(< 5 and < half of it)",
             label, t.free_rays, mean, edge);
    CHECK(name, t.free_rays > 0 && mean < 5.0 && mean < 0.5 * edge);
    /* A direction the map was not built for: no end. */
    vec3 other = v3_normalize(v3_add(dir, v3(0.01f, -0.02f, 0.015f)));
    vec3 p = v3_add(g->origin, v3(0.5f * size, 0.5f * size, 0.5f * size));
    snprintf(name, sizeof name, "%s: a ray in another direction keeps its end", label);
    CHECK(name, shadow_clip_end(&c, p, other, 7.0f) == 7.0f);
    shadow_clip_free(&c);
}

/* Light cones toward dir of the width whose proof level is K (as cone_cached_transmittance casts
 * them from a cell of level K - 1): past the map's end no element centre has a non-empty
 * neighbourhood on K. */
static void cone_level_checks(const char *label, const voxel_grid *g, vec3 dir, int K, uint64_t seed)
{
    shadow_clip c;
    char name[300];
    if (shadow_clip_build_cells(&c, g, K, SHADOW_CLIP_CONE_SIDE, SHADOW_CLIP_CONE_SLACK, dir) || !c.g) {
        printf("not ok %s, level %d: no map\n", label, K);
        unit_failures++;
        return;
    }
    float r = CONE_LIGHT_MIN_RADIUS * g->voxel_size * (float)(1u << (K - 1));
    int top = g->levels - 1;
    int proof = cone_proof_level(cone_element_level(r, 2.0f / g->voxel_size, top), top);
    cone_ctx x;
    memset(&x, 0, sizeof x);
    x.g = g; /* x.skip NULL: the sparse grid's columns */
    rng rr = rng_seed(seed, 1);
    const grid_level *L = &g->level[0];
    size_t step = L->count / 150 + 1;
    float size = g->n * g->voxel_size, cell = g->voxel_size * (float)(1u << K);
    int cones = 0, nonempty = 0, ended = 0;
    double samples = 0;
    for (size_t i = 0; i < L->count + 150; i += i < L->count ? step : 1) {
        vec3 org;
        if (i < L->count) { /* a voxel's centre, as the light cache casts its cones from cells' centres */
            int cx, cy, cz;
            grid_coords(g, 0, i, &cx, &cy, &cz);
            org = grid_cell_center(g, 0, cx, cy, cz);
        } else {
            org = v3_add(g->origin, v3(size * rng_float(&rr), size * rng_float(&rr), size * rng_float(&rr)));
        }
        cone cn = {org, dir, r, 0.0f, 0.0f, 1.0f, 1.0f, 0.125f * g->voxel_size};
        float t0, t1;
        if (!cone_clip_reach(g, &cn, &t0, &t1))
            continue;
        double o[3];
        grid_to_lattice(g, org, o);
        float end = shadow_clip_end_lattice(&c, o, dir, t1);
        cones++;
        ended += end < t1;
        if (!(end < t1))
            continue; /* nothing skipped */
        /* The elements the end skips start at or past it, before t1: their centres lie in
         * [end + r, t1 + r); sampled from the end on. */
        cone_walk w;
        cone_walk_start(&w, g, dir, 0.0f, t1);
        for (float tc = end > 0.0f ? end : 0.0f; tc < t1 + r; tc += 0.1f * cell) {
            vec3 p = v3_madd(org, dir, tc); /* as cone_next_element places a centre */
            double lat[3];
            cone_to_lattice(g, w.inv_voxel_size, p, lat);
            int cl[3];
            for (int a = 0; a < 3; a++)
                cl[a] = vx_floor_int(lat[a] * vx_inv_pow2(K));
            nonempty += !cone_neighbourhood_empty(&x, K, cl);
            samples++;
        }
    }
    snprintf(name, sizeof name,
             "%s, light cones of proof level %d (%d): no element centre past the end has a non-empty "
             "neighbourhood (%d cones, %.0f centres, %d non-empty)",
             label, K, proof, cones, samples, nonempty);
    CHECK(name, proof == K && cones > 0 && nonempty == 0);
    snprintf(name, sizeof name, "%s, light cones of proof level %d: the ends end (%d of %d before the grid's edge)",
             label, K, ended, cones);
    CHECK(name, ended > cones / 4);
    shadow_clip_free(&c);
}

static void scene_checks(const char *path, const int *resolutions, int nres)
{
    scene s;
    vx_err e;
    if (scene_load(path, &s, &e)) {
        printf("not ok load %s: %s\n", path, e.msg);
        unit_failures++;
        return;
    }
    rng r = rng_seed(99, 1);
    vec3 dirs[6] = {s.lights[0].direction, v3(0.0f, 1.0f, 0.0f), v3_normalize(v3(1.0f, 1.0f, 1.0f)),
                    v3_normalize(v3(-1e-4f, 1.0f, 2e-5f)), v3(0.0f, 0.0f, -1.0f), random_unit(&r)};
    for (int k = 0; k < nres; k++) {
        voxel_grid g;
        if (grid_build_scene(&g, &s, resolutions[k], NULL, NULL, &e)) {
            printf("not ok %s %d^3: %s\n", path, resolutions[k], e.msg);
            unit_failures++;
            continue;
        }
        for (int d = 0; d < 6; d++) {
            char label[200];
            snprintf(label, sizeof label, "%s %d^3, light (%.3g %.3g %.3g)", path, resolutions[k], dirs[d].x, dirs[d].y,
                     dirs[d].z);
            grid_checks(label, &g, dirs[d], 7 + (uint64_t)d);
            for (int K = 1; K <= 3 && K < g.levels; K++)
                cone_level_checks(label, &g, dirs[d], K, 70 + (uint64_t)(d * 4 + K));
        }
        grid_free(&g);
    }
    scene_free(&s);
}

static void clip_switch(render_options *o, int on) { o->shadow_clip = on; }

int main(void)
{
    const int bunny[] = {40, 100}, trees[] = {64}, city[] = {48};
    scene_checks("scenes/bunny.json", bunny, 2);
    scene_checks("scenes/trees.json", trees, 1);
    scene_checks("scenes/city.json", city, 1);
    const char *models[] = {"binary", "alpha", "vicini", "vmesh"};
    for (int k = 0; k < 4; k++) {
        render_toggle_checks("scenes/bunny.json", models[k], 48, clip_switch, "the shadow rays' ends");
        render_toggle_checks("scenes/trees.json", models[k], 48, clip_switch, "the shadow rays' ends");
    }
    render_toggle_checks("scenes/bunny.json", "heitz-neyret", 48, clip_switch, "the light cones' ends");
    render_toggle_checks("scenes/trees.json", "heitz-neyret", 48, clip_switch, "the light cones' ends");
    return unit_exit();
}
