/* The primary rays' empty-space skip (tracer/render/pixel_skip.h, issue 15) is exact:
 *  - brute force over the shipped scenes' grids (several resolutions, one not a power of two) and
 *    random groups of rays from one origin (the scene's camera, random points outside and inside
 *    the grid; 1 to 16 rays a few pixels apart, or far apart): for every ray, the DDA walk started
 *    at the skip's t reports exactly the cells, indices and [t0, t1] bits of the walk started at 0;
 *  - the field: a block's distance is the chessboard distance to the nearest non-empty block
 *    (capped), checked against a direct search on a small grid;
 *  - the skip skips: from the scenes' cameras most of the distance to the first non-empty cell;
 *  - render_image gives the same image, word for word, with and without it (binary, alpha and
 *    vmesh, bunny and trees, shadows declared), whether four pixels share a skip (1 and 4 spp, a
 *    row ending in a shorter span) or each pixel skips alone (5 spp). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "grid_scene.h"
#include "grid_walk.h"
#include "pixel_skip.h"
#include "render_toggle.h"
#include "rng.h"
#include "unit.h"

/* Random groups of rays against one grid; returns the rays whose walks differ. *skipped and *ahead
 * add up, over rays that hit something, the skip and the distance to the first non-empty cell. */
static int exactness(const voxel_grid *g, const grid_distance *ps, vec3 camera, vec3 look, int groups, uint64_t seed,
                     double *skipped, double *ahead, int *rays_out)
{
    static walk_cell full[WALK_MAX_CELLS], part[WALK_MAX_CELLS];
    rng r = rng_seed(seed, 0);
    vec3 lo = g->origin, size = v3(g->n * g->voxel_size, g->n * g->voxel_size, g->n * g->voxel_size);
    int bad = 0, rays = 0;
    for (int k = 0; k < groups; k++) {
        /* The origin: the camera (its rays toward the look-at point), or a random point in a box
         * twice the grid's (inside or outside it). */
        vec3 o = camera, centre;
        int kind = k % 3;
        if (kind == 0)
            centre = v3_normalize(v3_add(v3_sub(look, camera), v3_scale(random_unit(&r), 0.3f)));
        else {
            o = v3(lo.x + size.x * (2.0f * rng_float(&r) - 0.5f), lo.y + size.y * (2.0f * rng_float(&r) - 0.5f),
                   lo.z + size.z * (2.0f * rng_float(&r) - 0.5f));
            vec3 mid = v3_add(lo, v3_scale(size, 0.5f));
            centre = kind == 1 ? v3_normalize(v3_add(v3_sub(mid, o), v3_scale(random_unit(&r), 0.2f * v3_length(size))))
                               : random_unit(&r);
        }
        int count = 1 + (int)(rng_float(&r) * 16.0f);
        count = count > 16 ? 16 : count;
        /* A few neighbouring pixels' rays (voxel_render_span): within a few hundredths of a radian; one group in
         * eight far apart. */
        float spread = k % 8 == 7 ? 0.3f : 0.04f * rng_float(&r);
        vec3 dir[16];
        for (int i = 0; i < count; i++)
            dir[i] = i == 0 ? centre : v3_normalize(v3_add(centre, v3_scale(random_unit(&r), spread)));
        float t = pixel_skip_t(ps, o, dir, count);
        for (int i = 0; i < count; i++, rays++) {
            int nf = walk_cells(g, o, dir[i], 0.0f, INFINITY, full), np = walk_cells(g, o, dir[i], t, INFINITY, part);
            int same = walks_equal(full, nf, part, np);
            if (!same && bad < 5)
                printf("# differs: origin (%g %g %g) dir (%g %g %g), skip t %g: %d cells from 0, %d from t\n", o.x, o.y,
                       o.z, dir[i].x, dir[i].y, dir[i].z, t, nf, np);
            bad += !same;
            if (kind == 0 && nf > 0) {
                *skipped += t;
                *ahead += full[0].t0;
            }
        }
    }
    *rays_out += rays;
    return bad;
}

static void scene_checks(const char *path, const int *resolutions, int nres)
{
    scene s;
    vx_err e;
    char name[300];
    if (scene_load(path, &s, &e)) {
        printf("not ok load %s: %s\n", path, e.msg);
        unit_failures++;
        return;
    }
    vec3 look = v3_add(s.camera.position, s.camera.forward);
    for (int k = 0; k < nres; k++) {
        voxel_grid g;
        grid_distance ps;
        if (grid_build_scene(&g, &s, resolutions[k], NULL, NULL, &e) || grid_distance_build(&ps, &g)) {
            printf("not ok %s %d^3: %s\n", path, resolutions[k], e.msg);
            unit_failures++;
            continue;
        }
        double skipped = 0, ahead = 0;
        int rays = 0;
        int bad = exactness(&g, &ps, s.camera.position, look, 600, 17 + (uint64_t)k, &skipped, &ahead, &rays);
        snprintf(name, sizeof name, "%s %d^3: walks from the skip's t equal the walks from 0, bit for bit (%d rays, %d differ)",
                 path, resolutions[k], rays, bad);
        CHECK(name, bad == 0);
        snprintf(name, sizeof name, "%s %d^3: the camera's rays skip %.0f %% of the way to their first cell (> 50 %%)", path,
                 resolutions[k], ahead > 0 ? 100.0 * skipped / ahead : 0.0);
        CHECK(name, ahead > 0 && skipped > 0.5 * ahead);
        grid_distance_free(&ps);
        grid_free(&g);
    }
    scene_free(&s);
}

/* The field against a direct search: every block's distance on a 20^3 grid of the spheres scene. */
static void field_checks(void)
{
    scene s;
    vx_err e;
    voxel_grid g;
    grid_distance ps;
    if (scene_load("scenes/spheres.json", &s, &e) || grid_build_scene(&g, &s, 20, NULL, NULL, &e) ||
        grid_distance_build(&ps, &g)) {
        printf("not ok field: %s\n", e.msg);
        unit_failures++;
        return;
    }
    const grid_level *L = &g.level[ps.level];
    int n = ps.n, bad = 0, occupied = 0, far = 0;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++)
            for (int z = 0; z < n; z++) {
                int best = GRID_DISTANCE_CAP;
                for (int i = 0; i < n; i++)
                    for (int j = 0; j < n; j++)
                        for (int k = 0; k < n; k++)
                            if (grid_level_occupied(L, i, j, k)) {
                                int dx = abs(i - x), dy = abs(j - y), dz = abs(k - z);
                                int d = dx > dy ? dx : dy;
                                d = d > dz ? d : dz;
                                best = d < best ? d : best;
                            }
                int got = grid_distance_at(&ps, x, y, z);
                bad += got != best;
                occupied += best == 0;
                far += best >= 3;
            }
    char name[200];
    snprintf(name, sizeof name, "field: chessboard distances equal a direct search (%d^3 blocks at level %d, %d differ)", n,
             ps.level, bad);
    CHECK(name, bad == 0);
    CHECK("field: the grid has non-empty blocks and blocks 3 or more away (the check can fail)", occupied > 0 && far > 0);
    grid_distance_free(&ps);
    grid_free(&g);
    scene_free(&s);
}

/* render_image with and without the skip (the pixels' depth bounds off, since a frame with them does
 * not ask for the skip). */
static void skip_switch(render_options *o, int on)
{
    o->empty_skip = on;
    o->pixel_bounds = 0;
}

int main(void)
{
    field_checks();
    const int bunny[] = {48, 100, 256}, trees[] = {64, 128}, city[] = {96};
    scene_checks("scenes/bunny.json", bunny, 3);
    scene_checks("scenes/trees.json", trees, 2);
    scene_checks("scenes/city.json", city, 1);
    const char *models[] = {"binary", "alpha", "vmesh"};
    for (int k = 0; k < 3; k++) {
        render_toggle_checks("scenes/bunny.json", models[k], 64, skip_switch, "the skip");
        render_toggle_checks("scenes/trees.json", models[k], 64, skip_switch, "the skip");
    }
    return unit_exit();
}
