/* Front-to-back traversal of the non-empty cells of one level of a voxel_grid along a ray: a 3D-DDA
 * (Amanatides & Woo 1987) that skips empty space using the coarser MIP levels. The DDA runs over
 * blocks of 2^k cells (the cells k levels up): an empty block is stepped over like a cell, k goes
 * up while the parent block is empty too, and a non-empty block makes k go down (into the child the
 * ray is in) until single cells are reached. A ray through an empty region thus costs about log2 of
 * its length in steps rather than one per cell; a step is a few multiply-adds and one or two
 * occupancy lookups.
 *
 * Iterator style: grid_iter_init, then grid_iter_next until it returns 0; stop whenever you like.
 * The iterator is a plain value, so copying it saves the position; to resume from a distance t
 * later, init again with t_min = t. For a shadow ray toward a point light pass t_max = the
 * distance to the light (same units as t, i.e. in multiples of |dir|).
 *
 * Conventions:
 *  - t is the parameter of origin + t * dir in world space (dir need not be unit length); the
 *    reported [t0, t1] is the ray's overlap with the cell clipped to [t_min, t_max], t0 <= t1, and
 *    successive cells have non-decreasing t0 (t1 of one cell = t0 of the next, whether or not the
 *    cells in between were empty).
 *  - A cell is [x, x+1) on an axis where the ray does not move: a ray lying exactly in a grid
 *    plane (a zero direction component with the origin on a cell boundary) belongs to the cells
 *    above the plane, and one on the grid's upper boundary plane misses the grid.
 *  - Where the ray is moving, the starting cell is the one it occupies just after t_min (an
 *    origin on a boundary going down starts below it). A ray crossing an edge or corner exactly
 *    may report a cell with t0 == t1 there.
 *  - A zero or non-finite direction, a NaN origin or an invalid level gives no cells. */
#ifndef VX_GRID_TRAVERSE_H
#define VX_GRID_TRAVERSE_H

#include <stdint.h>

#include "grid.h"
#include "grid_traverse_core.h" /* grid_hit, grid_iter and the DDA itself (portable, shared with OpenCL) */

#ifdef __cplusplus
extern "C" {
#endif

/* Sets up the traversal of `level` for origin + t*dir, t in [t_min, t_max] (t_max may be
 * INFINITY). Returns 1 when the ray overlaps the grid (with positive length), 0 when it misses it
 * (the iterator then yields nothing). */
int grid_iter_init(grid_iter *it, const voxel_grid *g, int level, vec3 origin, vec3 dir, float t_min,
                   float t_max);

/* The next non-empty cell along the ray: fills *hit and returns 1, or returns 0 when there is none. */
int grid_iter_next(grid_iter *it, grid_hit *hit);

#ifdef __cplusplus
}
#endif

#endif
