/* View tiles (tracer/render/view_tile.h): the direction a model that asks for them gets for the
 * opacity of a voxel's cached answer toward the camera.
 *  - the bound the model interface promises: over random cameras (frames, fields of view, image
 *    heights, tiles of 1 to 16 pixels) and voxel centres anywhere in front of the camera, the
 *    direction turns by at most k / sqrt(2) pixels' angle (tile / sqrt(2) radians), computed in
 *    double from the returned vector; and the worst case comes above 0.8 of the bound (a lattice
 *    half as fine as asked would stay under 0.5 of it);
 *  - one direction per cell: centres at random depths projecting into one lattice cell get the same
 *    bits, and that direction passes through the cell's centre on the image plane (in double);
 *    neighbouring cells get other directions;
 *  - off: tile 0, or a centre beside or behind the eye (below VIEW_TILE_MIN_COS), gives the exact
 *    direction's own bits;
 *  - view_tile_width: k pixels of 2 spread each, 0 for none; render_view_tile_pixels, the tiles in
 *    effect for both backends and --stats: vmesh's 4 by default, 0 without the cache, with
 *    view_tiles off, for a model that asks for none (alpha) and for a cone model. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "render.h"
#include "rng.h"
#include "unit.h"
#include "view_tile.h"

static int same_vec(vec3 a, vec3 b) { return memcmp(&a, &b, sizeof a) == 0; }

static camera random_camera(rng *g)
{
    camera c;
    memset(&c, 0, sizeof c);
    vec3 f = v3_normalize(v3(2.0f * rng_float(g) - 1.0f, 2.0f * rng_float(g) - 1.0f, 2.0f * rng_float(g) - 1.0f));
    v3_basis(f, &c.right, &c.up);
    c.forward = f;
    c.position = v3(10.0f * rng_float(g) - 5.0f, 10.0f * rng_float(g) - 5.0f, 10.0f * rng_float(g) - 5.0f);
    c.tan_half_fov_y = tanf((10.0f + 70.0f * rng_float(g)) * 3.14159265f / 360.0f);
    return c;
}

/* The angle between a and b, in double. */
static double angle(vec3 a, vec3 b)
{
    double ax = a.x, ay = a.y, az = a.z, bx = b.x, by = b.y, bz = b.z;
    double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    return atan2(sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz);
}

/* Where the line from the eye along d meets the image plane at distance 1, in (right, up), double. */
static void plane_point(const camera *c, vec3 d, double *u, double *v)
{
    double along = (double)d.x * c->forward.x + (double)d.y * c->forward.y + (double)d.z * c->forward.z;
    *u = ((double)d.x * c->right.x + (double)d.y * c->right.y + (double)d.z * c->right.z) / along;
    *v = ((double)d.x * c->up.x + (double)d.y * c->up.y + (double)d.z * c->up.z) / along;
}

/* The unit vector from the camera toward point p. */
static vec3 from_camera(const camera *c, vec3 p) { return v3_normalize(v3_sub(p, c->position)); }

/* A point in front of the camera whose image-plane coordinates are (u, v), at distance `depth`
 * along the axis. */
static vec3 point_at(const camera *c, float u, float v, float depth)
{
    vec3 d = v3_add(c->forward, v3_add(v3_scale(c->right, u), v3_scale(c->up, v)));
    return v3_madd(c->position, d, depth);
}

int main(void)
{
    rng g = rng_seed(77, 0);
    char name[256];

    /* The bound, and how close to it the worst case comes. */
    double worst_ratio = 0.0;
    int over = 0, tried = 0;
    for (int k = 0; k < 20000; k++) {
        camera c = random_camera(&g);
        int height = 32 + (int)(rng_float(&g) * 1000.0f), pixels = 1 + (int)(rng_float(&g) * 16.0f) % 16;
        float tile = view_tile_width(pixels, camera_pixel_spread(&c, height));
        /* inside a frustum of half-angle up to about 80 degrees */
        float u = (2.0f * rng_float(&g) - 1.0f) * 5.0f, v = (2.0f * rng_float(&g) - 1.0f) * 5.0f;
        vec3 p = point_at(&c, u, v, 0.01f + 50.0f * rng_float(&g));
        vec3 exact = from_camera(&c, p);
        vec3 got = view_tile_direction(&c, tile, exact);
        double bound = (double)tile / sqrt(2.0), a = angle(got, exact);
        over += !(a <= bound * (1.0 + 1e-4) + 1e-6);
        worst_ratio = a / bound > worst_ratio ? a / bound : worst_ratio;
        tried++;
    }
    snprintf(name, sizeof name,
             "the direction turns by at most tile / sqrt(2) (%d centres, %d over, the worst %.4f of the bound)", tried,
             over, worst_ratio);
    CHECK(name, over == 0 && worst_ratio > 0.8);

    /* One direction per cell, through the cell's centre; neighbours differ. */
    int cells = 0, split = 0, off_centre = 0, same_as_neighbour = 0;
    for (int k = 0; k < 2000; k++) {
        camera c = random_camera(&g);
        float tile = view_tile_width(4, camera_pixel_spread(&c, 256));
        int i = (int)(rng_float(&g) * 60.0f) - 30, j = (int)(rng_float(&g) * 60.0f) - 30;
        vec3 first = {0};
        for (int n = 0; n < 8; n++) {
            /* a point well inside cell (i, j): away from its edges by a tenth of the cell */
            float u = ((float)i + 0.1f + 0.8f * rng_float(&g)) * tile, v = ((float)j + 0.1f + 0.8f * rng_float(&g)) * tile;
            vec3 got = view_tile_direction(&c, tile, from_camera(&c, point_at(&c, u, v, 0.5f + 20.0f * rng_float(&g))));
            if (n == 0)
                first = got;
            split += !same_vec(got, first);
        }
        double pu, pv;
        plane_point(&c, first, &pu, &pv);
        off_centre += fabs(pu - ((double)i + 0.5) * tile) > 1e-4 * tile + 1e-6 || fabs(pv - ((double)j + 0.5) * tile) > 1e-4 * tile + 1e-6;
        vec3 next = view_tile_direction(&c, tile, from_camera(&c, point_at(&c, ((float)i + 1.5f) * tile, ((float)j + 0.5f) * tile, 3.0f)));
        same_as_neighbour += same_vec(next, first);
        cells++;
    }
    snprintf(name, sizeof name,
             "centres in one cell get one direction, through the cell's centre; the next cell another (%d cells: %d "
             "split, %d off centre, %d like the neighbour)",
             cells, split, off_centre, same_as_neighbour);
    CHECK(name, cells == 2000 && split == 0 && off_centre == 0 && same_as_neighbour == 0);

    /* Off. */
    int kept = 0, n_off = 0;
    for (int k = 0; k < 1000; k++) {
        camera c = random_camera(&g);
        vec3 p = point_at(&c, 2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f, 1.0f + rng_float(&g));
        vec3 exact = from_camera(&c, p);
        kept += same_vec(view_tile_direction(&c, 0.0f, exact), exact);
        /* behind the eye, and beside it (cosine 0.05 with the axis) */
        vec3 behind = v3_madd(c.position, c.forward, -1.0f - rng_float(&g));
        vec3 beside = v3_add(c.position, v3_add(v3_scale(c.right, 1.0f), v3_scale(c.forward, 0.05f)));
        vec3 tb = from_camera(&c, behind), ts = from_camera(&c, beside);
        kept += same_vec(view_tile_direction(&c, 0.01f, tb), tb) + same_vec(view_tile_direction(&c, 0.01f, ts), ts);
        n_off += 3;
    }
    snprintf(name, sizeof name, "tile 0, or a centre behind or beside the eye: the exact direction's bits (%d of %d)",
             kept, n_off);
    CHECK(name, kept == n_off);

    camera c = random_camera(&g);
    float spread = camera_pixel_spread(&c, 200);
    CHECK("view_tile_width: k pixels of 2 spread each",
          view_tile_width(4, spread) == 8.0f * spread && view_tile_width(1, spread) == 2.0f * spread);
    CHECK("view_tile_width: 0 for no tiles", view_tile_width(0, spread) == 0.0f);

    const vx_model *vmesh = model_find("vmesh"), *alpha = model_find("alpha"), *hn = model_find("heitz-neyret");
    render_options o, no_cache, exact;
    render_default_options(&o);
    no_cache = exact = o;
    no_cache.cache = 0;
    exact.view_tiles = 0;
    CHECK("render_view_tile_pixels: vmesh's 4 by default; 0 without the cache or with view tiles off",
          vmesh && render_view_tile_pixels(vmesh, &o) == 4 && render_view_tile_pixels(vmesh, &no_cache) == 0 &&
              render_view_tile_pixels(vmesh, &exact) == 0);
    CHECK("render_view_tile_pixels: 0 for a model that asks for none (alpha) and a cone model (heitz-neyret)",
          alpha && hn && render_view_tile_pixels(alpha, &o) == 0 && render_view_tile_pixels(hn, &o) == 0);
    return unit_exit();
}
