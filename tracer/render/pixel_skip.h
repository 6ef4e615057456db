/* Empty-space skipping for a pixel's primary rays (C backend): how far all of a pixel's rays can
 * jump before their DDA, without passing a non-empty voxel.
 *
 * Why: issue 15's profile. A primary ray spends most of its time approaching the surface through
 * empty space: about 16 hierarchical DDA steps at ~20 ns each on bunny 256^3, 4 rays per pixel
 * taking nearly the same path. Here one walk per pixel, along its first ray, jumps by a chessboard
 * distance field ("proximity clouds", Cohen & Sheffer 1994) and stops where any of the pixel's rays
 * could be near a non-empty block; every ray then starts its DDA there.
 *
 * Exact, not an approximation: each jump is sized so that every ray of the group stays inside a
 * cube of blocks known to be empty (the distance at the walk's point, less the rays' spread from
 * the first ray, less a margin far above rounding). So the cells a ray's DDA would have reported
 * before the returned t are none, and from there the DDA visits the same cells with the same
 * [t0, t1] (every distance the walk reports is a plane crossing computed by one formula, see
 * grid_traverse_core.h): images are bit-identical with and without the skip (tests/unit_pixel_skip.c,
 * tests/unit_render.c).
 *
 * The field: per block of one MIP level (the finest with at most PIXEL_SKIP_MAX_N blocks a side),
 * the chessboard distance in blocks to the nearest non-empty block, capped at PIXEL_SKIP_CAP;
 * n^3 bytes (262 KB at 64^3). The rays must share their origin (a pinhole camera; with depth of
 * field the caller does not skip). */
#ifndef VX_PIXEL_SKIP_H
#define VX_PIXEL_SKIP_H

#include "grid_core.h"

#define PIXEL_SKIP_MAX_N 64
#define PIXEL_SKIP_CAP 32

typedef struct {
    int level;           /* the MIP level whose blocks the field covers */
    int n;               /* blocks a side */
    double block;        /* a block's edge in world units */
    double lo[3], hi[3]; /* the grid's box in world units */
    unsigned char *dist; /* n^3, index (x * n + y) * n + z; NULL: no field (every skip is 0) */
} pixel_skip;

/* Builds the field of g (an empty grid gets one too: every ray then skips the whole grid). Returns 0,
 * or -1 when out of memory (s->dist NULL). */
int pixel_skip_build(pixel_skip *s, const voxel_grid *g);
void pixel_skip_free(pixel_skip *s);

/* The largest t found such that none of the `count` rays org + t dir[i] (shared origin) meets a
 * non-empty voxel before t: each ray's DDA may start at t_min = this. 0 when nothing can be skipped. */
float pixel_skip_t(const pixel_skip *s, vec3 org, const vec3 *dir, int count);

#endif
