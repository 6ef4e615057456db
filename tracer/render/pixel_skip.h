/* Empty-space skipping for a pixel's primary rays (C backend): how far all of a pixel's rays can
 * jump before their DDA, without passing a non-empty voxel.
 *
 * Why: issue 15's profile. A primary ray spent most of its time approaching the surface through
 * empty space: about 16 hierarchical DDA steps at ~20 ns each on bunny 256^3, 4 rays per pixel
 * taking nearly the same path. Here one walk per group of rays (a few neighbouring pixels' rays, see
 * voxel_render_span), along its first ray, jumps by the grid's distance field (grid_distance.h) and
 * stops where any of the group's rays could be near a non-empty block; every ray then starts its
 * DDA there.
 *
 * Exact, not an approximation: each jump is sized so that every ray of the group stays inside a
 * cube of blocks known to be empty (the distance at the walk's point, less the rays' spread from
 * the first ray, less a margin far above rounding). So the cells a ray's DDA would have reported
 * before the returned t are none, and from there the DDA visits the same cells with the same
 * [t0, t1] (every distance the walk reports is a plane crossing computed by one formula, see
 * grid_traverse_core.h): images are bit-identical with and without the skip
 * (tests/unit_pixel_skip.c). The rays must share their origin (a pinhole camera; with depth of
 * field the caller does not skip). */
#ifndef VX_PIXEL_SKIP_H
#define VX_PIXEL_SKIP_H

#include "grid_distance.h"
#include "vec.h"

/* The largest t found such that none of the `count` rays org + t dir[i] (shared origin) meets a
 * non-empty voxel before t: each ray's DDA may start at t_min = this. 0 when nothing can be skipped
 * (also without a field). */
float pixel_skip_t(const grid_distance *s, vec3 org, const vec3 *dir, int count);

#endif
