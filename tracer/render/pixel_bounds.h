/* The primary rays' depth bounds per pixel: the nearest and the farthest depth at which any ray of
 * a pixel can meet a non-empty voxel. Every voxel (or, when the grid has over 3 voxels a pixel, every
 * non-empty block of the finest MIP level with at most that many) is projected onto the image: its
 * box in the camera's axes gives a conservative rectangle of pixels, widened by a margin, and a
 * range of depths along the camera's axis, which the map's cells under the rectangle take in, like a
 * z-buffer that keeps both ends. A cell is 2 x 2 pixels. A pixel's rays then start their walk at its
 * near bound (no voxel lies before it on any of them) and end it at its far bound (none lies
 * beyond): the walks report the same cells with the same [t0, t1] as walks over the whole ray,
 * since every non-empty cell on a ray lies wholly between the bounds by the margin. A pixel that no
 * voxel covers has nothing to walk, and when every ray of the frame is certain to be bounded
 * (pixel_bounds_all_forward) it makes no rays (pixel_bounds_pixel_empty).
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

/* A map cell is 2^PIXEL_BOUNDS_TILE_SHIFT pixels a side (why 2: pixel_bounds.c). A constant, so
 * that a ray finds its cell by shifts, not two integer divisions. */
#define PIXEL_BOUNDS_TILE_SHIFT 1

typedef struct {
    int width, height; /* the image */
    int map_w, map_h;  /* the map's cells (PIXEL_BOUNDS_TILE_SHIFT), map_w x map_h of them */
    float *near_t, *far_t; /* width * height each, row-major: the depths along the camera's axis
                            * (not t) of the nearest and farthest voxel over the pixel; near
                            * INFINITY: nothing; NULL: no map */
    float *part;           /* the threads' own maps while building */
    int parts;
    int failed; /* a voxel straddles the camera's plane: no map for this frame */
    int forward_rays; /* every primary ray of the frame has dir . forward > 0, so pixel_bounds_ray
                       * bounds each of them (pixel_bounds_all_forward) */
} pixel_bounds;

/* Allocates the map and the threads' parts for a width x height image (before the clock starts).
 * Returns 0, or -1 when out of memory. */
int pixel_bounds_alloc(pixel_bounds *b, int width, int height, int threads);
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
    return (size_t)(py >> PIXEL_BOUNDS_TILE_SHIFT) * (size_t)b->map_w + (size_t)(px >> PIXEL_BOUNDS_TILE_SHIFT);
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

/* Narrows [*t_min, *t_max] to where ray org + t dir of pixel (px, py) can meet a non-empty voxel
 * (org: the camera's position). The map holds depths along the camera's axis, and a point of the
 * ray at depth Z lies at t = Z / (dir . forward), whatever dir's length; a relative 1e-6 covers the
 * rounding. A pixel that no voxel covers gets an empty interval (t_min INFINITY). */
static inline void pixel_bounds_ray(const pixel_bounds *b, vec3 forward, int px, int py, vec3 dir, float *t_min,
                                    float *t_max)
{
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
    float tn = (float)((double)b->near_t[i] * inv_c * (1.0 - 1e-6));
    float tf = (float)((double)b->far_t[i] * inv_c * (1.0 + 1e-6));
    *t_min = tn > *t_min ? tn : *t_min;
    *t_max = tf < *t_max ? tf : *t_max;
}

#endif
