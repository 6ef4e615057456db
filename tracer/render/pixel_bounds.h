/* The primary rays' depth bounds per pixel: the nearest and the farthest depth at which any ray of
 * a pixel can meet a non-empty voxel. Every voxel (or, when the grid has over 3 voxels a pixel, every
 * non-empty block of the finest MIP level with at most that many) is projected onto the image: its
 * box in the camera's axes gives a conservative rectangle of pixels, widened by a margin, and a
 * range of depths along the camera's axis, which the map's cells under the rectangle take in, like a
 * z-buffer that keeps both ends (a cell: a pixel or a square of them). A pixel's rays then start
 * their walk at its near bound (no voxel lies before it on any of them) and end it at its far bound
 * (none lies beyond): the walks report the same cells with the same [t0, t1] as walks over the whole
 * ray, since every non-empty cell on a ray lies wholly between the bounds by the margin. A pixel
 * that no voxel covers has nothing to walk, and when every ray of the frame is certain to be bounded
 * (pixel_bounds_all_forward) it makes no rays (pixel_bounds_pixel_empty). The voxel marcher's map
 * (for the models that walk on past a voxel, not first hit) also keeps, per cell, which of 64
 * depth slabs its voxels' depth ranges touch (or-ed, so in no order); a ray then walks each run of
 * such slabs in turn and jumps over the slabs between them, where no voxel lies
 * (pixel_bounds_ray_spans, pixel_spans_next): the same cells again, by the same margins.
 *
 * It depends on the camera, so it is built per frame, inside the frame's clock, with the render's
 * threads (each takes a share of the voxels into its own map, then the maps are merged by pixel).
 * Pinhole cameras only (a thin lens' rays do not leave from one point), and only when every voxel
 * lies wholly in front of the camera or wholly behind it (else a voxel's image has no bounded
 * rectangle and the map is not made). C backend only; the OpenCL kernels walk the whole ray, with
 * the same result. */
#ifndef VX_PIXEL_BOUNDS_H
#define VX_PIXEL_BOUNDS_H

#include "camera.h"
#include "grid_core.h"

typedef struct {
    int width, height; /* the image */
    int tile_shift;    /* a map cell is 2^tile_shift pixels a side (pixel_bounds_alloc), so that a ray
                        * finds its cell by shifts, not two integer divisions */
    int map_w, map_h;  /* the map's cells, map_w x map_h of them */
    float *near_t, *far_t; /* map_w * map_h each, row-major: the depths along the camera's axis
                            * (not t) of the nearest and farthest voxel over the cell; near
                            * INFINITY: nothing; NULL: no map */
    float *part;           /* the threads' own maps while building */
    int parts;
    int failed; /* a voxel straddles the camera's plane: no map for this frame */
    int forward_rays; /* every primary ray of the frame has dir . forward > 0, so pixel_bounds_ray
                       * bounds each of them (pixel_bounds_all_forward) */
    /* The depth slabs (pixel_bounds_alloc_slabs; NULL: not kept): bit s of a cell's word is set when
     * a voxel over the cell may have depths in slab s, [z0 + s dz, z0 + (s + 1) dz), the first slab
     * reaching down to -infinity and the last up to +infinity. */
    uint64_t *slabs, *slab_part; /* map_w x map_h words; the threads' own while building */
    double slab_z0, slab_dz;
} pixel_bounds;

/* A cell keeps PIXEL_BOUNDS_SLABS depth slabs, spread evenly over the grid's depths in the frame:
 * a ray then walks only the runs of slabs that may hold a voxel, not the empty depths between them
 * (the inside of a closed surface: alpha on bunny 256^3 spent half its walk's steps between one
 * voxel and the next more than two voxels on). */
#define PIXEL_BOUNDS_SLABS 64

/* What a primary ray has left to walk after its first run of slabs (pixel_bounds_ray_spans). */
typedef struct {
    uint64_t slabs;     /* the slabs after the current run that may hold a voxel; 0: nothing more */
    double z0, dz;      /* the map's slabs */
    double inv_c;       /* 1 / (dir . forward): a depth Z lies at t = Z inv_c along the ray */
    float t_far;        /* the ray's far bound */
} pixel_spans;

/* The voxel marcher's cells (render_voxel.c): one pixel, not 2 x 2. The map's build costs more,
 * each voxel marking about four to nine cells instead of one to four, but the rays start their
 * walks nearer their first voxel. Instructions inside a 256^3 frame's clock at 256 x 256
 * (callgrind, one thread), per pixel against per 2 x 2: binary -1.2 / -1.3 / -4.4 % (bunny / city /
 * trees), alpha -1.6 / -0.6 / -2.3 %, vmesh -1.2 / -0.2 / -1.6 %, vicini -0.7 / -0.4 / -1.5 %; on
 * bunny's binary frame the build went from 28.8 to 36.8 M and the walks from 233.9 to 222.8 M. In
 * wall time the gain is within the host's noise (paired, best of 30 frames, 2 threads, bunny alpha:
 * 40.1 / 39.9 / 40.5 ms with 2 x 2, 38.8 / 38.7 / 38.8 with one pixel); an older comparison, with
 * the code of its day, had favoured 2 x 2 (binary 22.8 ms with 1, 19.4 with 2). */
#define VOXEL_BOUNDS_TILE_SHIFT 0

/* Allocates the map and the threads' parts for a width x height image, its cells 2^tile_shift pixels
 * a side (0 .. 4), before the clock starts. Larger cells make a cheaper map with looser bounds (the
 * rays start their walks earlier): the marchers choose (VOXEL_BOUNDS_TILE_SHIFT above,
 * cone_camera_ends.h's CONE_ENDS_TILE_SHIFT). Returns 0, or -1 when out of memory (or a tile_shift
 * out of range). */
int pixel_bounds_alloc(pixel_bounds *b, int width, int height, int tile_shift, int threads);
/* Adds the depth slabs to an allocated map (the voxel marcher's; the cones' ends do without): 0, or -1
 * when out of memory. */
int pixel_bounds_alloc_slabs(pixel_bounds *b);
void pixel_bounds_free(pixel_bounds *b);
size_t pixel_bounds_bytes(const pixel_bounds *b);

/* Builds the map of grid g for camera cam with the given threads (at most the allocated parts). */
void pixel_bounds_build(pixel_bounds *b, const voxel_grid *g, const camera *cam, int threads);

/* Whether a block of `level` whose depths along the camera's axis span [z_near, z_far] goes in. */
typedef int (*pixel_bounds_keep)(const void *ctx, int level, double z_near, double z_far);

/* The general build, of which pixel_bounds_build is one case: the non-empty blocks of levels
 * level_lo .. level_hi, each taken as the cube of `grow` of its own cells about its centre (1: the
 * block; 3: its 3x3x3 neighbourhood) widened by `margin` (world units) more on every side, those that
 * keep accepts (NULL: all; a block it refuses cannot fail the map). The camera cones' ends
 * (cone_camera_ends.c) are built so. */
void pixel_bounds_build_cells(pixel_bounds *b, const voxel_grid *g, const camera *cam, int threads, int level_lo,
                              int level_hi, double grow, double margin, pixel_bounds_keep keep, const void *keep_ctx);

/* Whether pixel_bounds_build(b, g, cam) may make no map (a block straddling the camera's plane),
 * asked before the frame's clock: the frames that have a map never ask for the distance-field skip,
 * so it is built only for those that may not. The test runs over the build's blocks or coarser
 * ones, each holding the finer blocks inside it, with a wider margin than the build's: 0 is
 * certain (the build will make its map), 1 may be needlessly cautious. */
int pixel_bounds_may_fail(const pixel_bounds *b, const voxel_grid *g, const camera *cam);

/* Whether the map holds bounds for this frame. */
static inline int pixel_bounds_active(const pixel_bounds *b) { return b->near_t && !b->failed; }

/* The map cell of pixel (px, py). */
static inline size_t pixel_bounds_cell(const pixel_bounds *b, int px, int py)
{
    return (size_t)(py >> b->tile_shift) * (size_t)b->map_w + (size_t)(px >> b->tile_shift);
}

/* dir . forward as pixel_bounds_ray computes it (in double): a ray is bounded when it is positive. */
static inline double pixel_bounds_axis_cos(vec3 forward, vec3 dir)
{
    return (double)dir.x * forward.x + (double)dir.y * forward.y + (double)dir.z * forward.z;
}

/* Whether every ray camera_ray makes for a pinhole camera cam and a width x height image has
 * dir . forward > 0 as pixel_bounds_ray computes it (in double, from the float direction), proven from
 * the camera's axes by a bound on the float rounding; 0 when that is not certain (a view of nearly
 * 180 degrees across a very wide image, or axes far from orthonormal). */
int pixel_bounds_all_forward(const camera *cam, int width, int height);

/* Whether every ray of pixel (px, py) meets nothing: its map cell holds no voxel and, every ray of
 * the frame being bounded by the map, each of them gets an empty interval from pixel_bounds_ray
 * (so walks no cell and takes the background). */
static inline int pixel_bounds_pixel_empty(const pixel_bounds *b, int px, int py)
{
    return pixel_bounds_active(b) && b->forward_rays && b->near_t[pixel_bounds_cell(b, px, py)] == INFINITY;
}

/* The t at which a ray (inv_c = 1 / (dir . forward)) reaches depth Z, a relative 1e-6 before (lo) or
 * after it: far more than the rounding of the depths (floats, relative 6e-8) and of the product. */
static inline float pixel_bounds_depth_t(double Z, double inv_c, int lo)
{
    return (float)(Z * inv_c * (lo ? 1.0 - 1e-6 : 1.0 + 1e-6));
}

/* The run of slabs starting at the lowest bit of *slabs: narrows [*t_min, *t_max] to its depths and
 * clears its bits from *slabs. The first slab has no lower end and the last no upper one. */
static inline void pixel_spans_take_run(uint64_t *slabs, double z0, double dz, double inv_c, float *t_min,
                                        float *t_max)
{
    uint64_t m = *slabs;
    int first = __builtin_ctzll(m);
    uint64_t above = ~(m >> first); /* zero bits from `first` on: the run's end */
    int last = above ? first + __builtin_ctzll(above) - 1 : PIXEL_BOUNDS_SLABS - 1;
    *slabs = last == PIXEL_BOUNDS_SLABS - 1 ? 0 : m & (~(uint64_t)0 << (last + 1));
    if (first > 0) {
        float lo = pixel_bounds_depth_t(z0 + (double)first * dz, inv_c, 1);
        *t_min = lo > *t_min ? lo : *t_min;
    }
    if (*slabs) { /* the last run ends at the far bound */
        float hi = pixel_bounds_depth_t(z0 + (double)(last + 1) * dz, inv_c, 0);
        *t_max = hi < *t_max ? hi : *t_max;
    }
}

/* Narrows [*t_min, *t_max] to where ray org + t dir of pixel (px, py) can meet a non-empty voxel
 * (org: the camera's position), and, when rest is not NULL and the map has its slabs, further to the
 * first run of slabs that may hold one; *rest then holds the runs after it (pixel_spans_next), else
 * nothing. The map holds depths along the camera's axis, and a point of the ray at depth Z lies at
 * t = Z / (dir . forward), whatever dir's length. A pixel that no voxel covers gets an empty
 * interval (t_min INFINITY). */
static inline void pixel_bounds_ray_spans(const pixel_bounds *b, vec3 forward, int px, int py, vec3 dir, float *t_min,
                                          float *t_max, pixel_spans *rest)
{
    if (rest)
        rest->slabs = 0;
    if (!pixel_bounds_active(b))
        return;
    size_t i = pixel_bounds_cell(b, px, py);
    double c = pixel_bounds_axis_cos(forward, dir);
    if (!(c > 0.0))
        return;
    if (b->near_t[i] == INFINITY) {
        *t_min = INFINITY;
        return;
    }
    /* One division: the reciprocal's rounding (an ulp) is far inside the margin. */
    double inv_c = 1.0 / c;
    float tn = pixel_bounds_depth_t(b->near_t[i], inv_c, 1), tf = pixel_bounds_depth_t(b->far_t[i], inv_c, 0);
    *t_min = tn > *t_min ? tn : *t_min;
    *t_max = tf < *t_max ? tf : *t_max;
    if (!rest || !b->slabs)
        return;
    rest->slabs = b->slabs[i];
    rest->z0 = b->slab_z0;
    rest->dz = b->slab_dz;
    rest->inv_c = inv_c;
    rest->t_far = *t_max;
    pixel_spans_take_run(&rest->slabs, rest->z0, rest->dz, inv_c, t_min, t_max);
}

/* pixel_bounds_ray_spans without the slabs: [*t_min, *t_max] narrowed to the pixel's two bounds. */
static inline void pixel_bounds_ray(const pixel_bounds *b, vec3 forward, int px, int py, vec3 dir, float *t_min,
                                    float *t_max)
{
    pixel_bounds_ray_spans(b, forward, px, py, dir, t_min, t_max, NULL);
}

/* The ray's next run of slabs after the one it has walked: 1 with its interval in [*t_min, *t_max]
 * (the last run's reaching to the ray's far bound), 0 when there is none. */
static inline int pixel_spans_next(pixel_spans *rest, float *t_min, float *t_max)
{
    if (!rest->slabs)
        return 0;
    *t_min = 0.0f; /* a later run's first slab is not the first: its lower end is set */
    *t_max = rest->t_far;
    pixel_spans_take_run(&rest->slabs, rest->z0, rest->dz, rest->inv_c, t_min, t_max);
    return 1;
}

#endif
