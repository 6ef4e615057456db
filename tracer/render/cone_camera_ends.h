/* The camera cones' ends: where each pixel's cone stops asking the model about elements (the C
 * backend's CONE_CAMERA_END, render_cone.c). pixel_bounds.h's per-pixel map, built per frame inside
 * its clock from the non-empty cells of the cones' proof levels (cone_levels.h), each grown into the
 * cube of its 3x3x3 neighbourhood, as the light cones' ends are (shadow_clip.h). The marcher asks
 * the model about an element exactly when the element's centre lies in such a cube of its own proof
 * level; a pixel's cone runs along the pixel's centre ray, so past the farthest cube over the pixel
 * it asks about nothing more, and a pixel that no cube covers asks about nothing at all and is not
 * marched (bunny 256^3, 256 x 256: 25 thousand of the 65 thousand cones, of the 27 thousand that ask
 * about nothing and climbed through empty space to the grid's edge; city 30 thousand, trees 23).
 * Exact: a cone's elements, and so its pixel, are the same bits. The walk's jumps
 * before the first element cannot be cut so (where they land places every element after them).
 *
 * A cell counts only on the proof levels the cones can have at its depths (bounded with the pixels'
 * least and greatest cone spreads; the proof level grows with the radius, and the radius along a
 * cone): else the top level's one cell, whose neighbourhood is the whole grid, would cover every
 * pixel. Pinhole cameras only: a thin lens' cones narrow toward the focus. */
#ifndef VX_CONE_CAMERA_ENDS_H
#define VX_CONE_CAMERA_ENDS_H

#include <math.h>

#include "camera.h"
#include "grid_core.h"
#include "pixel_bounds.h"

/* The map's cells are 2 x 2 pixels (pixel_bounds_alloc's tile_shift), not one as the voxel marcher's
 * bounds: a block goes in as its 3x3x3 neighbourhood, whose wide rectangle covers about four times as
 * many cells of one pixel. heitz-neyret with one pixel a cell: +1.0 / +2.1 / +0.6 % instructions
 * inside a 256^3 frame's clock at 256 x 256 (bunny / city / trees; callgrind, one thread). */
#define CONE_ENDS_TILE_SHIFT 1

/* Builds the map of grid g for pinhole camera cam on b's image (pixel_bounds_alloc'd), the cones'
 * spread per unit distance being `spread` (camera_pixel_spread), with the given threads. */
void cone_camera_ends_build(pixel_bounds *b, const voxel_grid *g, const camera *cam, float spread, int threads);

/* The same map with every level's blocks looked at, not only those of the levels that the grid's
 * depths allow (the check of that choice, tests/unit_cone_ends.c): the same map, slower. */
void cone_camera_ends_build_every_level(pixel_bounds *b, const voxel_grid *g, const camera *cam, float spread,
                                        int threads);

/* The t past which the cone of pixel (px, py), along its centre ray's unit direction dir from the
 * camera, asks about no element: INFINITY without a map, -INFINITY when it asks about none. */
static inline float cone_camera_end(const pixel_bounds *b, vec3 forward, int px, int py, vec3 dir)
{
    float t_min = 0.0f, t_max = INFINITY;
    pixel_bounds_ray(b, forward, px, py, dir, &t_min, &t_max);
    return t_min == INFINITY ? -INFINITY : t_max;
}

#endif
