/* The primary rays' depth bounds per pixel (see pixel_bounds.h). */
#include "pixel_bounds.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "grid.h"
#include "parallel.h"
#include "prefault.h"
#include "vec_d.h"

/* The voxels are split into this many shares; each thread folds the shares it takes into its own
 * map (min and max do not depend on the order, so neither does the map). */
#define BOUNDS_SHARES 64
#define BOUNDS_ITEMS_PER_PIXEL 3
/* Cells of up to 16 x 16 pixels: the marchers use 1 x 1 and 2 x 2, and larger cells only loosen the
 * bounds further (a shift past the int's width would be undefined). */
#define BOUNDS_MAX_TILE_SHIFT 4

/* Margins, far above the float rounding of the camera's rays (relative 1e-7 of a direction: 1e-5 of
 * a pixel) and of the DDA's cells (1e-13 of a voxel), far below anything that changes how much a ray
 * walks: 1 % of a voxel added to every block's half-extents, 1 % of a pixel to every rectangle (and
 * a relative 1e-6 to the depths, in pixel_bounds_ray). */
#define BOUNDS_RADIUS_MARGIN 0.01
#define BOUNDS_PIXEL_MARGIN 0.01

/* Resets a thread's map (near and far side by side, one cache line for both): nothing seen yet. */
static void reset_part(float *pairs, size_t pixels)
{
    for (size_t i = 0; i < pixels; i++) {
        pairs[2 * i] = INFINITY;
        pairs[2 * i + 1] = -INFINITY;
    }
}

int pixel_bounds_alloc(pixel_bounds *b, int width, int height, int tile_shift, int threads)
{
    memset(b, 0, sizeof *b);
    if (tile_shift < 0 || tile_shift > BOUNDS_MAX_TILE_SHIFT)
        return -1;
    int tile = 1 << tile_shift;
    int mw = (width + tile - 1) / tile, mh = (height + tile - 1) / tile;
    size_t pixels = (size_t)mw * (size_t)mh;
    threads = threads < 1 ? 1 : threads;
    b->near_t = malloc(2 * pixels * sizeof *b->near_t);
    b->part = malloc(2 * pixels * (size_t)threads * sizeof *b->part);
    if (!b->near_t || !b->part) {
        pixel_bounds_free(b);
        return -1;
    }
    b->far_t = b->near_t + pixels;
    b->width = width;
    b->height = height;
    b->tile_shift = tile_shift;
    b->map_w = mw;
    b->map_h = mh;
    b->parts = threads;
    /* The parts start empty (here, before the frame's clock, which also touches their pages) and
     * every build leaves them so (bounds_merge empties what it reads). */
    for (int t = 0; t < threads; t++)
        reset_part(b->part + 2 * pixels * (size_t)t, pixels);
    for (size_t i = 0; i < pixels; i++) /* the map's pages too */
        b->near_t[i] = b->far_t[i] = INFINITY;
    return 0;
}

int pixel_bounds_alloc_slabs(pixel_bounds *b)
{
    size_t pixels = (size_t)b->map_w * (size_t)b->map_h;
    /* Empty, as every build leaves them, and touched here, before the clock, as the depths are
     * (prefault.h: calloc, or malloc and memset, which GCC folds into one, left them to fault in
     * during the first frame, 77 more page faults inside its clock on bunny 256x256). */
    b->slabs = vx_alloc_touched(pixels * sizeof *b->slabs, 0);
    b->slab_part = vx_alloc_touched(pixels * (size_t)b->parts * sizeof *b->slab_part, 0);
    if (!b->slabs || !b->slab_part) {
        free(b->slabs);
        free(b->slab_part);
        b->slabs = b->slab_part = NULL;
        return -1;
    }
    return 0;
}

void pixel_bounds_free(pixel_bounds *b)
{
    free(b->near_t);
    free(b->part);
    free(b->slabs);
    free(b->slab_part);
    memset(b, 0, sizeof *b);
}

size_t pixel_bounds_bytes(const pixel_bounds *b)
{
    size_t cells = (size_t)b->map_w * (size_t)b->map_h * (size_t)(1 + b->parts);
    return b->near_t ? cells * (2 * sizeof(float) + (b->slabs ? sizeof(uint64_t) : 0)) : 0;
}

typedef struct {
    pixel_bounds *b;
    const voxel_grid *g;
    double pos[3], right[3], up[3], fwd[3];
    double x_scale, y_scale; /* image pixels per unit of the camera's image plane (at distance 1) */
    int level_lo, level_hi;  /* the levels whose blocks go in */
    double grow;             /* a block's edge in its own cells (1, or 3 for its neighbourhood) */
    double margin;           /* world units added to every block's half-extents */
    pixel_bounds_keep keep;  /* NULL: every block */
    const void *keep_ctx;
    double slab_per_dz;      /* 1 / b->slab_dz, when b->slabs */
    int failed[64];          /* per thread (parallel_for's threads are fewer) */
} bounds_job;

static double min2(double a, double b) { return a < b ? a : b; }
static double max2(double a, double b) { return a > b ? a : b; }

/* The centre of non-empty block i of `level` (blocks of size vs) relative to the camera at pos: what
 * the map's build and pixel_bounds_may_fail both project. */
static inline void block_from_camera(const voxel_grid *g, int level, size_t i, double vs, const double pos[3],
                                     double q[3])
{
    int c[3];
    grid_coords(g, level, i, &c[0], &c[1], &c[2]);
    for (int a = 0; a < 3; a++)
        q[a] = g->origin_d[a] + ((double)c[a] + 0.5) * vs - pos[a];
}

/* The slabs that depths [z_near, z_far] may touch: a thousandth of a slab more each way than the
 * slabs' own ends (pixel_spans_take_run computes them as z0 + s dz, to a relative 1e-16), and the
 * depths beyond the first and last slab in those (whose ends are open). */
static uint64_t slab_bits(const bounds_job *J, double z_near, double z_far)
{
    double z0 = J->b->slab_z0;
    double lo = floor((z_near - z0) * J->slab_per_dz - 1e-3), hi = floor((z_far - z0) * J->slab_per_dz + 1e-3);
    int first = lo > 0.0 ? (lo < PIXEL_BOUNDS_SLABS - 1 ? (int)lo : PIXEL_BOUNDS_SLABS - 1) : 0;
    int last = hi > 0.0 ? (hi < PIXEL_BOUNDS_SLABS - 1 ? (int)hi : PIXEL_BOUNDS_SLABS - 1) : 0; /* NaN: 0 */
    last = last > first ? last : first;
    return (~(uint64_t)0 >> (PIXEL_BOUNDS_SLABS - 1 - last)) & (~(uint64_t)0 << first);
}

/* One block: its box in the camera's axes (centre q from the camera, half-extents hx, hy, hz) into
 * the thread's map (and its slabs, when not NULL), or the thread's failure when it straddles the
 * camera's plane. */
static inline void bounds_block(bounds_job *J, float *pairs, uint64_t *slabs, const double q[3], double hx, double hy,
                                double hz, double vs, int level, int thread)
{
    pixel_bounds *b = J->b;
    double Z = vx_dot3d(q, J->fwd);
    if (Z + hz <= 0.0)
        return; /* wholly behind the camera: its rays (forward of it) cannot meet it */
    if (J->keep && !J->keep(J->keep_ctx, level, Z - hz, Z + hz))
        return;
    if (Z - hz <= 1e-3 * vs) {
        J->failed[thread] = 1; /* its image is not bounded */
        return;
    }
    double X = vx_dot3d(q, J->right), Y = vx_dot3d(q, J->up);
    /* The cube lies in [X - hx, X + hx] x [Y - hy, Y + hy] x [Z - hz, Z + hz] (camera axes); X / Z
     * over that box is extreme at its corners. */
    double inv = 1.0 / ((Z - hz) * (Z + hz)), zn = (Z + hz) * inv, zf = (Z - hz) * inv; /* 1 / (Z -+ hz) */
    double sx0 = min2((X - hx) * zn, (X - hx) * zf), sx1 = max2((X + hx) * zn, (X + hx) * zf);
    double sy0 = min2((Y - hy) * zn, (Y - hy) * zf), sy1 = max2((Y + hy) * zn, (Y + hy) * zf);
    /* camera_ray: x = (sx / (tan * aspect) + 1) w / 2, y = (1 - sy / tan) h / 2. */
    double x0 = (sx0 * J->x_scale + 1.0) * 0.5 * b->width - BOUNDS_PIXEL_MARGIN;
    double x1 = (sx1 * J->x_scale + 1.0) * 0.5 * b->width + BOUNDS_PIXEL_MARGIN;
    double y0 = (1.0 - sy1 * J->y_scale) * 0.5 * b->height - BOUNDS_PIXEL_MARGIN;
    double y1 = (1.0 - sy0 * J->y_scale) * 0.5 * b->height + BOUNDS_PIXEL_MARGIN;
    if (x1 < 0.0 || y1 < 0.0 || x0 >= b->width || y0 >= b->height)
        return;
    int px0 = x0 > 0.0 ? (int)x0 : 0, py0 = y0 > 0.0 ? (int)y0 : 0;
    int px1 = x1 < b->width - 1 ? (int)x1 : b->width - 1, py1 = y1 < b->height - 1 ? (int)y1 : b->height - 1;
    px0 >>= b->tile_shift; /* >= 0 */
    py0 >>= b->tile_shift;
    px1 >>= b->tile_shift;
    py1 >>= b->tile_shift;
    /* Depths along the camera's axis (pixel_bounds_ray turns them into each ray's t); rounding
     * to float (relative 6e-8) stays inside pixel_bounds_ray's relative margin. */
    float tn = (float)(Z - hz), tf = (float)(Z + hz);
    /* The slabs from the depths before their rounding to float: the slabs' margin covers only the
     * doubles' rounding. */
    uint64_t bits = slabs ? slab_bits(J, Z - hz, Z + hz) : 0;
    for (int py = py0; py <= py1; py++)
        for (int px = px0; px <= px1; px++) {
            size_t k = (size_t)py * (size_t)b->map_w + (size_t)px;
            float *pair = pairs + 2 * k;
            pair[0] = tn < pair[0] ? tn : pair[0];
            pair[1] = tf > pair[1] ? tf : pair[1];
            if (slabs)
                slabs[k] |= bits;
        }
}

static void bounds_share(void *p, int64_t share, int thread)
{
    bounds_job *J = p;
    pixel_bounds *b = J->b;
    const voxel_grid *g = J->g;
    size_t pixels = (size_t)b->map_w * (size_t)b->map_h;
    float *pairs = b->part + 2 * pixels * (size_t)thread;
    uint64_t *slabs = b->slabs ? b->slab_part + pixels * (size_t)thread : NULL;
    for (int level = J->level_lo; level <= J->level_hi && !J->failed[thread]; level++) {
        const grid_level *L = &g->level[level];
        size_t first = L->count * (size_t)share / BOUNDS_SHARES, last = L->count * (size_t)(share + 1) / BOUNDS_SHARES;
        const double vs = g->voxel_size_d * (double)(1 << level);
        /* A block's half-extents along the camera's axes, widened. */
        double half[3];
        for (int k = 0; k < 3; k++) {
            const double *a = k == 0 ? J->right : (k == 1 ? J->up : J->fwd);
            double cells = vx_cube_half_extent(a) * (double)(1 << level) * J->grow;
            half[k] = (cells + BOUNDS_RADIUS_MARGIN) * g->voxel_size_d + J->margin;
        }
        for (size_t i = first; i < last && !J->failed[thread]; i++) {
            double q[3];
            block_from_camera(g, level, i, vs, J->pos, q);
            bounds_block(J, pairs, slabs, q, half[0], half[1], half[2], vs, level, thread);
        }
    }
}

static void bounds_reset(void *p, int64_t part, int thread)
{
    (void)thread;
    bounds_job *J = p;
    size_t pixels = (size_t)J->b->map_w * (size_t)J->b->map_h;
    reset_part(J->b->part + 2 * pixels * (size_t)part, pixels);
    if (J->b->slabs)
        memset(J->b->slab_part + pixels * (size_t)part, 0, pixels * sizeof *J->b->slab_part);
}

static void bounds_merge(void *p, int64_t row, int thread)
{
    (void)thread;
    bounds_job *J = p;
    pixel_bounds *b = J->b;
    size_t pixels = (size_t)b->map_w * (size_t)b->map_h;
    for (size_t k = (size_t)row * (size_t)b->map_w; k < (size_t)(row + 1) * (size_t)b->map_w; k++) {
        float n = INFINITY, f = -INFINITY;
        for (int t = 0; t < b->parts; t++) {
            float *pair = b->part + 2 * (pixels * (size_t)t + k);
            n = pair[0] < n ? pair[0] : n;
            f = pair[1] > f ? pair[1] : f;
            pair[0] = INFINITY; /* empty again for the next build */
            pair[1] = -INFINITY;
        }
        b->near_t[k] = n;
        b->far_t[k] = f;
        if (b->slabs) {
            uint64_t bits = 0; /* or-ed: the threads' order does not matter */
            for (int t = 0; t < b->parts; t++) {
                bits |= b->slab_part[pixels * (size_t)t + k];
                b->slab_part[pixels * (size_t)t + k] = 0;
            }
            b->slabs[k] = bits;
        }
    }
}

/* The slabs for camera axis fwd from pos: the grid's cube's depths, from the camera's plane on, in
 * PIXEL_BOUNDS_SLABS equal parts (blocks beyond them fall in the open first or last slab). */
static void slabs_for_frame(bounds_job *J, const voxel_grid *g)
{
    double zmin = INFINITY, zmax = -INFINITY, side = (double)g->n * g->voxel_size_d;
    for (int k = 0; k < 8; k++) {
        double p[3];
        for (int a = 0; a < 3; a++)
            p[a] = g->origin_d[a] + ((k >> a) & 1 ? side : 0.0) - J->pos[a];
        double Z = vx_dot3d(p, J->fwd);
        zmin = Z < zmin ? Z : zmin;
        zmax = Z > zmax ? Z : zmax;
    }
    zmin = zmin > 0.0 ? zmin : 0.0;
    double dz = (zmax - zmin) / PIXEL_BOUNDS_SLABS;
    if (!(dz > 0.0) || !isfinite(dz) || !isfinite(zmin)) {
        zmin = 0.0; /* nothing in front, or no sense: one slab holds all (they are all or-ed alike) */
        dz = INFINITY;
    }
    J->b->slab_z0 = zmin;
    J->b->slab_dz = dz;
    J->slab_per_dz = 1.0 / dz;
}

/* The level whose blocks the map is built from: the finest with at most BOUNDS_ITEMS_PER_PIXEL
 * blocks a pixel. */
static int bounds_level(const pixel_bounds *b, const voxel_grid *g)
{
    int level = 0;
    while (level + 1 < g->levels && g->level[level].count > BOUNDS_ITEMS_PER_PIXEL * (size_t)b->width * (size_t)b->height)
        level++;
    return level;
}

void pixel_bounds_build_cells(pixel_bounds *b, const voxel_grid *g, const camera *cam, int threads, int level_lo,
                              int level_hi, double grow, double margin, pixel_bounds_keep keep, const void *keep_ctx)
{
    if (!b->near_t)
        return;
    threads = threads < 1 ? 1 : (threads > b->parts ? b->parts : threads);
    threads = threads > 64 ? 64 : threads;
    bounds_job J;
    memset(&J, 0, sizeof J);
    J.b = b;
    J.g = g;
    const vec3 *axes[4] = {&cam->position, &cam->right, &cam->up, &cam->forward};
    double *out[4] = {J.pos, J.right, J.up, J.fwd};
    for (int k = 0; k < 4; k++) {
        out[k][0] = axes[k]->x;
        out[k][1] = axes[k]->y;
        out[k][2] = axes[k]->z;
    }
    double tan_y = cam->tan_half_fov_y, aspect = (double)b->width / (double)b->height;
    J.x_scale = 1.0 / (tan_y * aspect);
    J.y_scale = 1.0 / tan_y;
    J.level_lo = level_lo < 0 ? 0 : level_lo;
    J.level_hi = level_hi < g->levels ? level_hi : g->levels - 1;
    J.grow = grow;
    J.margin = margin;
    J.keep = keep;
    J.keep_ctx = keep_ctx;
    b->failed = 0;
    b->forward_rays = pixel_bounds_all_forward(cam, b->width, b->height);
    if (b->slabs)
        slabs_for_frame(&J, g);
    parallel_for(BOUNDS_SHARES, threads, bounds_share, &J, NULL);
    for (int t = 0; t < threads; t++)
        b->failed |= J.failed[t];
    if (!b->failed)
        parallel_for(b->map_h, threads, bounds_merge, &J, NULL);
    else
        parallel_for(b->parts, threads, bounds_reset, &J, NULL); /* no map: empty the parts again */
}

int pixel_bounds_all_forward(const camera *cam, int width, int height)
{
    /* camera_ray's direction is d = f + sx r + sy u normalised, |sx| <= S = tan * aspect and
     * |sy| <= T = tan (the image's edges). Exactly, d . f >= |f|^2 - S |r . f| - T |u . f|. The float
     * sums making d err by a few ulps of M = |f| + S |r| + T |u| per component, the normalisation by
     * a few ulps of each component of a positive multiple of d, and the double dot product by far
     * less: together under 1e-6 M |f| of d . f's scale (2^-24 is 6e-8), so 1e-5 M |f| of slack
     * leaves the sign certain. */
    double f[3] = {cam->forward.x, cam->forward.y, cam->forward.z}, r[3] = {cam->right.x, cam->right.y, cam->right.z},
           u[3] = {cam->up.x, cam->up.y, cam->up.z};
    double T = fabs((double)cam->tan_half_fov_y), S = T * fabs((double)width / (double)height);
    double nf = sqrt(vx_dot3d(f, f)), M = nf + S * sqrt(vx_dot3d(r, r)) + T * sqrt(vx_dot3d(u, u));
    double least = vx_dot3d(f, f) - S * fabs(vx_dot3d(r, f)) - T * fabs(vx_dot3d(u, f)) - 1e-5 * M * nf;
    return least > 0.0; /* also false for NaN */
}

void pixel_bounds_build(pixel_bounds *b, const voxel_grid *g, const camera *cam, int threads)
{
    /* The blocks of the finest level with at most BOUNDS_ITEMS_PER_PIXEL a pixel: the map's cost is
     * then about the image's, not the grid's, and a block stays about a pixel's size or smaller
     * (bunny 256^3, 256 x 256: voxels; city, with 337k voxels: blocks of 2^3). */
    int level = b->near_t ? bounds_level(b, g) : 0;
    pixel_bounds_build_cells(b, g, cam, threads, level, level, 1.0, 0.0, NULL, NULL);
}

/* Blocks the coarse test looks at, at most: well under a millisecond. */
#define MAY_FAIL_BLOCKS 65536

int pixel_bounds_may_fail(const pixel_bounds *b, const voxel_grid *g, const camera *cam)
{
    int level = bounds_level(b, g); /* the build's blocks, or coarser ones holding them */
    while (level + 1 < g->levels && g->level[level].count > MAY_FAIL_BLOCKS)
        level++;
    const grid_level *L = &g->level[level];
    const double pos[3] = {cam->position.x, cam->position.y, cam->position.z};
    const double fwd[3] = {cam->forward.x, cam->forward.y, cam->forward.z};
    const double vs = g->voxel_size_d * (double)(1 << level);
    /* bounds_share's test on a block that is one of the build's or holds some: its extent along the
     * camera's axis covers theirs, its threshold (1e-3 of a block) is at least theirs, and twice
     * their margin leaves the doubles' rounding no way to pass a block whose contents fail. */
    const double hz = (vx_cube_half_extent(fwd) * (double)(1 << level) + 2 * BOUNDS_RADIUS_MARGIN) * g->voxel_size_d;
    for (size_t i = 0; i < L->count; i++) {
        double q[3];
        block_from_camera(g, level, i, vs, pos, q);
        double Z = vx_dot3d(q, fwd);
        if (Z + hz > 0.0 && Z - hz <= 1e-3 * vs)
            return 1;
    }
    return 0;
}
