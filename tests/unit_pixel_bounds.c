/* The primary rays' depth bounds per pixel (tracer/render/pixel_bounds.h, issue 15) are exact:
 *  - brute force over the shipped scenes' grids (a resolution that is not a power of two; city at
 *    96^3 on a small image, where the map is made of 2^3 blocks), two image shapes and map cells of
 *    1 and 2 x 2 pixels (the voxel marcher's and the camera cones' ends'): for rays
 *    through random points of random pixels (their edges included), the walk over the interval
 *    pixel_bounds_ray gives reports exactly the cells, indices and [t0, t1] bits of the walk over
 *    the whole ray, and no non-empty voxel's box touches the ray outside the interval (slab tests
 *    against every voxel, not the DDA);
 *  - the same for the depth slabs' spans (pixel_bounds_ray_spans, pixel_spans_next): the walks over
 *    them, one after the other, report exactly the cells and [t0, t1] bits of the walk over the whole
 *    ray, no voxel's box touches the ray outside them, and they do leave gaps (a span's end half a
 *    slab short fails both);
 *  - the bounds bound: a hit ray's walk starts most of the way to its first cell;
 *  - the map is the same, bit for bit, whatever the thread count and whatever was built before;
 *  - a camera inside a voxel gets no map (a voxel straddling the camera's plane has no bounded
 *    image);
 *  - pixel_bounds_may_fail, which decides before the clock whether a frame may need the distance
 *    field, is sound: over random cameras (in and around the grid, some at voxels' corners and
 *    looking along the grid's axes, where the camera's plane grazes voxel faces) every one whose
 *    build makes no map was foretold, and it does not cry wolf for the scenes' own cameras;
 *  - render_image gives the same image, word for word, with and without the bounds (binary, alpha,
 *    vicini and vmesh, bunny and trees; without them the empty-space skip is used). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cone_camera_ends.h"
#include "grid_scene.h"
#include "grid_walk.h"
#include "pixel_bounds.h"
#include "render_toggle.h"
#include "rng.h"
#include "unit.h"

/* The spans a ray walks: pixel_bounds_ray_spans' first and pixel_spans_next's after it. */
#define MAX_SPANS (PIXEL_BOUNDS_SLABS / 2 + 1)
static int ray_spans(const pixel_bounds *b, vec3 forward, int px, int py, vec3 d, float lo[MAX_SPANS], float hi[MAX_SPANS])
{
    pixel_spans rest;
    lo[0] = 0.0f;
    hi[0] = INFINITY;
    pixel_bounds_ray_spans(b, forward, px, py, d, &lo[0], &hi[0], &rest);
    int n = 1;
    while (n < MAX_SPANS && pixel_spans_next(&rest, &lo[n], &hi[n]))
        n++;
    return n;
}

/* Brute force, independent of the DDA: the non-empty voxels whose closed box the ray touches
 * somewhere that no span [lo[i], hi[i]] holds whole. */
static int voxels_outside_spans(const voxel_grid *g, vec3 o, vec3 d, const float *lo, const float *hi, int n)
{
    const grid_level *L = &g->level[0];
    const double od[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
    int outside = 0;
    for (size_t i = 0; i < L->count; i++) {
        int c[3];
        grid_coords(g, 0, i, &c[0], &c[1], &c[2]);
        double bl[3], bh[3], a, b;
        for (int k = 0; k < 3; k++) {
            bl[k] = g->origin_d[k] + c[k] * g->voxel_size_d;
            bh[k] = g->origin_d[k] + (c[k] + 1) * g->voxel_size_d;
        }
        if (!vx_ray_box(od, dd, bl, bh, 0.0, &a, &b))
            continue;
        int held = 0;
        for (int s = 0; s < n && !held; s++)
            held = a >= lo[s] && b <= hi[s];
        outside += !held;
    }
    return outside;
}

static void image_checks(const char *label, const voxel_grid *g, const camera *cam, const camera *inside, int w, int h,
                         int tile_shift, uint64_t seed)
{
    static walk_cell full[WALK_MAX_CELLS], part[WALK_MAX_CELLS], spanned[WALK_MAX_CELLS];
    char name[300];
    pixel_bounds b, b1;
    if (pixel_bounds_alloc(&b, w, h, tile_shift, 2) || pixel_bounds_alloc(&b1, w, h, tile_shift, 3) ||
        pixel_bounds_alloc_slabs(&b) || pixel_bounds_alloc_slabs(&b1)) {
        printf("not ok %s: out of memory\n", label);
        unit_failures++;
        return;
    }
    /* b is built for two other cameras first (one inside a voxel: no map): a build must not keep
     * anything of the one before. */
    camera other = *cam;
    other.position = v3_add(cam->position, v3_scale(cam->right, 0.3f * v3_length(cam->position)));
    pixel_bounds_build(&b, g, inside, 2);
    pixel_bounds_build(&b, g, &other, 2);
    pixel_bounds_build(&b, g, cam, 2);
    pixel_bounds_build(&b1, g, cam, 1);
    snprintf(name, sizeof name, "%s: the map is made", label);
    CHECK(name, pixel_bounds_active(&b));
    size_t bytes = (size_t)b.map_w * (size_t)b.map_h * sizeof(float);
    snprintf(name, sizeof name,
             "%s: the map is the same with 1 and 2 threads, and after builds for other cameras, bit for bit", label);
    CHECK(name, memcmp(b.near_t, b1.near_t, bytes) == 0 && memcmp(b.far_t, b1.far_t, bytes) == 0 &&
                    memcmp(b.slabs, b1.slabs, bytes / sizeof(float) * sizeof(uint64_t)) == 0 &&
                    b.slab_z0 == b1.slab_z0 && b.slab_dz == b1.slab_dz);
    rng r = rng_seed(seed, 0);
    int rays = 0, differ = 0, outside = 0, hits = 0, span_differ = 0, span_outside = 0, gapped = 0;
    double skipped = 0.0, bounded = 0.0;
    double gap = 0.0, way = 0.0;
    for (int k = 0; k < 1500; k++) {
        int px = (int)(rng_float(&r) * w), py = (int)(rng_float(&r) * h);
        px = px < w ? px : w - 1;
        py = py < h ? py : h - 1;
        /* A random point of the pixel, one time in four on its edges. */
        float fx = rng_float(&r), fy = rng_float(&r);
        if (k % 4 == 1)
            fx = 0.0f;
        if (k % 4 == 2)
            fy = 0.99999994f;
        vec3 o, d;
        camera_ray(cam, w, h, (float)px + fx, (float)py + fy, 0.0f, 0.0f, 0, &o, &d);
        float t_min = 0.0f, t_max = INFINITY;
        pixel_bounds_ray(&b, cam->forward, px, py, d, &t_min, &t_max);
        int nf = walk_cells(g, o, d, 0.0f, INFINITY, full), np = walk_cells(g, o, d, t_min, t_max, part);
        int same = walks_equal(full, nf, part, np);
        if (!same && differ < 5)
            printf("# differs: pixel (%d %d) + (%g %g), [%g, %g]: %d cells over the ray, %d in the bounds\n", px, py, fx,
                   fy, t_min, t_max, nf, np);
        differ += !same;
        outside += voxels_outside(g, o, d, 0.0, t_min, t_max);
        /* The spans: their walks, one after the other, are the walk over the whole ray. */
        float lo[MAX_SPANS], hi[MAX_SPANS];
        int ns = ray_spans(&b, cam->forward, px, py, d, lo, hi), nw = 0;
        for (int k2 = 0; k2 < ns; k2++)
            nw += walk_cells(g, o, d, lo[k2], hi[k2], spanned + nw);
        int same_spans = walks_equal(full, nf, spanned, nw) && lo[0] == t_min && hi[ns - 1] == t_max;
        if (!same_spans && span_differ < 5)
            printf("# spans differ: pixel (%d %d) + (%g %g): %d spans, %d cells, %d over the ray\n", px, py, fx, fy, ns,
                   nw, nf);
        span_differ += !same_spans;
        span_outside += voxels_outside_spans(g, o, d, lo, hi, ns);
        if (t_min < t_max) {
            bounded += t_max - t_min;
            for (int k2 = 1; k2 < ns; k2++)
                skipped += lo[k2] - hi[k2 - 1];
            gapped += ns > 1;
        }
        rays++;
        if (nf > 0) {
            hits++;
            gap += (full[0].t0 - t_min) / g->voxel_size;
            way += full[0].t0 / g->voxel_size;
        }
    }
    snprintf(name, sizeof name, "%s: walks within the bounds equal walks over the whole ray, bit for bit (%d rays, %d differ)",
             label, rays, differ);
    CHECK(name, differ == 0);
    snprintf(name, sizeof name, "%s: no voxel's box touches a ray outside its bounds (slab tests, %d touch)", label,
             outside);
    CHECK(name, outside == 0);
    snprintf(name, sizeof name,
             "%s: %d hit rays start %.2f voxels before their first cell on average, of %.1f from the camera (< 15 %%)",
             label, hits, hits ? gap / hits : 0.0, hits ? way / hits : 0.0);
    CHECK(name, hits > 100 && gap < 0.15 * way);
    snprintf(name, sizeof name,
             "%s: walks over the depth slabs' spans, one after the other, equal walks over the whole ray, bit for bit "
             "(%d rays, %d differ; %d have gaps, %.0f %% of their bounds skipped)",
             label, rays, span_differ, gapped, bounded > 0.0 ? 100.0 * skipped / bounded : 0.0);
    CHECK(name, span_differ == 0 && gapped > 0 && skipped > 0.0);
    snprintf(name, sizeof name, "%s: no voxel's box touches a ray outside its spans (slab tests, %d touch)", label,
             span_outside);
    CHECK(name, span_outside == 0);
    pixel_bounds_free(&b);
    pixel_bounds_free(&b1);
}

/* pixel_bounds_may_fail against the build itself (see the top of this file). */
static void may_fail_checks(const char *label, const voxel_grid *g, const camera *scene_cam, const camera *inside,
                            int w, int h)
{
    char name[300];
    pixel_bounds b;
    if (pixel_bounds_alloc(&b, w, h, VOXEL_BOUNDS_TILE_SHIFT, 2)) {
        printf("not ok %s: out of memory\n", label);
        unit_failures++;
        return;
    }
    snprintf(name, sizeof name, "%s: the scene's camera is foretold a map, and a camera inside a voxel none", label);
    CHECK(name, !pixel_bounds_may_fail(&b, g, scene_cam) && pixel_bounds_may_fail(&b, g, inside));
    rng r = rng_seed(5, 1);
    vec3 lo = v3((float)g->origin_d[0], (float)g->origin_d[1], (float)g->origin_d[2]);
    float side = (float)(g->n * g->voxel_size_d);
    int failed = 0, unforetold = 0, made = 0, foretold_made = 0;
    for (int k = 0; k < 600; k++) {
        camera c = *scene_cam;
        if (k % 3 == 2) { /* a corner of a non-empty voxel, looking along an axis */
            size_t i = (size_t)(rng_float(&r) * (float)g->level[0].count) % g->level[0].count;
            int cx, cy, cz;
            grid_coords(g, 0, i, &cx, &cy, &cz);
            vec3 vlo, vhi;
            grid_cell_corners(g, 0, cx, cy, cz, &vlo, &vhi);
            c.position = vlo;
            int a = k / 3 % 3; /* the axis */
            c.forward = v3(a == 0 ? 1.0f : 0.0f, a == 1 ? 1.0f : 0.0f, a == 2 ? 1.0f : 0.0f);
            if (rng_float(&r) < 0.5f)
                c.forward = v3_scale(c.forward, -1.0f);
        } else { /* anywhere in a box 2.5 times the grid's, any direction */
            c.position = v3_add(lo, v3(side * (2.5f * rng_float(&r) - 0.75f), side * (2.5f * rng_float(&r) - 0.75f),
                                       side * (2.5f * rng_float(&r) - 0.75f)));
            c.forward = random_unit(&r);
        }
        camera_face(&c, c.forward);
        int may_fail = pixel_bounds_may_fail(&b, g, &c);
        pixel_bounds_build(&b, g, &c, 2);
        if (!pixel_bounds_active(&b)) {
            failed++;
            unforetold += !may_fail;
        } else {
            made++;
            foretold_made += !may_fail;
        }
    }
    printf("# %s: %d of 600 cameras got no map (%d not foretold); %d got one, %d of them foretold\n", label, failed,
           unforetold, made, foretold_made);
    snprintf(name, sizeof name, "%s: every camera that gets no map was foretold (%d of them)", label, failed);
    CHECK(name, failed > 50 && unforetold == 0);
    snprintf(name, sizeof name, "%s: most cameras that get a map are foretold one", label);
    CHECK(name, made > 50 && foretold_made * 10 >= made * 7);
    pixel_bounds_free(&b);
}

static void scene_checks(const char *path, int res)
{
    scene s;
    vx_err e;
    voxel_grid g;
    if (scene_load(path, &s, &e) || grid_build_scene(&g, &s, res, NULL, NULL, &e)) {
        printf("not ok %s %d^3: %s\n", path, res, e.msg);
        unit_failures++;
        return;
    }
    char label[200];
    /* The camera at a voxel's centre: that voxel straddles its plane. */
    camera inside = s.camera;
    vec3 lo, hi;
    int cx, cy, cz;
    grid_coords(&g, 0, g.level[0].count / 2, &cx, &cy, &cz);
    grid_cell_corners(&g, 0, cx, cy, cz, &lo, &hi);
    inside.position = v3_scale(v3_add(lo, hi), 0.5f);
    /* The camera cones' ends' cells (2 x 2 pixels) on an image whose sides they do not divide, and
     * the voxel marcher's (one pixel). */
    const int sizes[2][3] = {{63, 41, CONE_ENDS_TILE_SHIFT}, {150, 150, VOXEL_BOUNDS_TILE_SHIFT}};
    for (int k = 0; k < 2; k++) {
        snprintf(label, sizeof label, "%s %d^3, %dx%d, cells of %d pixels", path, res, sizes[k][0], sizes[k][1],
                 1 << (2 * sizes[k][2]));
        image_checks(label, &g, &s.camera, &inside, sizes[k][0], sizes[k][1], sizes[k][2], 11 + (uint64_t)k);
    }
    snprintf(label, sizeof label, "%s: the scene's camera has every ray forward (empty pixels skip their rays)", path);
    CHECK(label, pixel_bounds_all_forward(&s.camera, 256, 256) && pixel_bounds_all_forward(&s.camera, 64, 40));
    pixel_bounds b;
    if (pixel_bounds_alloc(&b, 32, 32, VOXEL_BOUNDS_TILE_SHIFT, 2) == 0) {
        pixel_bounds_build(&b, &g, &inside, 2);
        float t_min = 0.0f, t_max = INFINITY;
        pixel_bounds_ray(&b, inside.forward, 3, 4, inside.forward, &t_min, &t_max);
        snprintf(label, sizeof label, "%s %d^3: a camera inside a voxel gets no map, and its rays keep [0, inf)", path, res);
        CHECK(label, !pixel_bounds_active(&b) && t_min == 0.0f && t_max == INFINITY);
        pixel_bounds_free(&b);
    }
    /* A small image: the map's blocks are coarse, and the test looks at the same ones. A large
     * one on a grid of over 65536 voxels: the test looks at coarser blocks than the map's. */
    snprintf(label, sizeof label, "%s %d^3, 16x12", path, res);
    may_fail_checks(label, &g, &s.camera, &inside, 16, 12);
    if (g.level[0].count > 65536) {
        snprintf(label, sizeof label, "%s %d^3, 256x256", path, res);
        may_fail_checks(label, &g, &s.camera, &inside, 256, 256);
    }
    grid_free(&g);
    scene_free(&s);
}

/* pixel_bounds_all_forward, which lets a pixel whose map cell is empty skip making its rays, is
 * sound: over cameras of every field of view a scene accepts (to 179 degrees), image shapes from
 * 4096x1 to 1x4096 and axes orthonormal (as scene.c makes them) or skewed, whenever it says every
 * ray points forward, camera_ray's rays through the image's corners, edges, centre and random
 * points all have pixel_bounds_axis_cos > 0 (what pixel_bounds_ray bounds). It is not vacuous:
 * skewed cameras with rays that do turn back exist among them (and are refused). */
static void forward_checks(void)
{
    rng g = rng_seed(41, 0);
    const int shapes[][2] = {{256, 256}, {64, 40}, {4096, 1}, {1, 4096}, {3000, 7}, {7, 3000}};
    const double fovs[] = {1, 40, 90, 150, 170, 178, 179};
    int cameras = 0, claimed = 0, unsound = 0, turning = 0;
    for (int c = 0; c < 420; c++) {
        camera cam;
        memset(&cam, 0, sizeof cam);
        vec3 f = v3(2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f);
        vec3 up = v3(2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f);
        if (v3_length(v3_cross(f, up)) < 1e-3f)
            continue;
        cam.forward = v3_normalize(f);
        cam.right = v3_normalize(v3_cross(cam.forward, up));
        cam.up = v3_cross(cam.right, cam.forward);
        if (c % 3 == 2) /* skewed: up leans toward or away from forward */
            cam.up = v3_normalize(v3_madd(cam.up, cam.forward, 2.0f * rng_float(&g) - 1.0f));
        cam.tan_half_fov_y = (float)tan(fovs[c % 7] * 3.14159265358979323846 / 360.0);
        int w = shapes[(c / 7) % 6][0], h = shapes[(c / 7) % 6][1];
        int all = pixel_bounds_all_forward(&cam, w, h), back = 0;
        const float xs[] = {0.0f, nextafterf((float)w, 0.0f), 0.5f * (float)w, (float)w * rng_float(&g)};
        const float ys[] = {0.0f, nextafterf((float)h, 0.0f), 0.5f * (float)h, (float)h * rng_float(&g)};
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++) {
                vec3 o, d;
                camera_ray(&cam, w, h, xs[i], ys[j], 0.0f, 0.0f, 0, &o, &d);
                back |= !(pixel_bounds_axis_cos(cam.forward, d) > 0.0);
            }
        cameras++;
        claimed += all;
        unsound += all && back;
        turning += back;
    }
    char name[240];
    snprintf(name, sizeof name,
             "all_forward: every camera it passes (%d of %d) has every ray forward; %d have rays turning back", claimed,
             cameras, turning);
    CHECK(name, unsound == 0 && claimed > cameras / 2 && turning > 0);
}

static void bounds_switch(render_options *o, int on) { o->pixel_bounds = on; }

int main(void)
{
    forward_checks();
    pixel_bounds bad;
    CHECK("a map's cells of 2^5 pixels a side are refused, and nothing is left allocated",
          pixel_bounds_alloc(&bad, 64, 64, 5, 1) == -1 && pixel_bounds_alloc(&bad, 64, 64, -1, 1) == -1 &&
              !bad.near_t && !bad.part && pixel_bounds_bytes(&bad) == 0);
    scene_checks("scenes/bunny.json", 100);
    scene_checks("scenes/trees.json", 64);
    scene_checks("scenes/city.json", 96);
    scene_checks("scenes/bunny.json", 256);
    const char *models[] = {"binary", "alpha", "vicini", "vmesh"};
    for (int k = 0; k < 4; k++) {
        render_toggle_checks("scenes/bunny.json", models[k], 48, bounds_switch, "the depth bounds");
        render_toggle_checks("scenes/trees.json", models[k], 48, bounds_switch, "the depth bounds");
    }
    return unit_exit();
}
