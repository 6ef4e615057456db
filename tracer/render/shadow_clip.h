/* Where a shadow ray toward a directional light can stop: past every voxel in its way.
 *
 * All shadow rays toward one directional light are parallel, so each follows one column of a map
 * over the plane across the light's direction. The map holds, per column, the farthest any
 * non-empty voxel overlapping that column reaches toward the light (a voxel's cube projects into
 * a hexagon; its bounding rectangle, widened by a margin, marks the columns). A ray in that column
 * meets no non-empty voxel once it is past that reach, so its walk can end there: the walk reports
 * the same cells with the same [t0, t1] (each of them lies wholly before the end, by the margin),
 * and the shadow is the same bits, while the climb out of the grid through empty space is not
 * walked (alpha, bunny 256^3: the shadow rays' DDA steps fall from 2.0 to 1.1 million a frame, and
 * the frame from 62.6 to 55.4 ms). A ray whose column holds no voxel at all has nothing to meet:
 * its walk is empty.
 *
 * Built per directional light by the C backend's render set-up (outside the frame's clock, like the
 * primary rays' distance field) in one pass over the non-empty voxels; the OpenCL kernels walk to the
 * grid's edge, with the same result. Everything is in the grid's lattice units (one voxel = 1), in
 * double, as the DDA's own mapping (grid_traverse_core.h).
 *
 * The same map over the cells of a coarser MIP level, each grown into a larger cube about its centre
 * (shadow_clip_build_cells), ends the cone marcher's light cones: a cone element is asked of the
 * model only where a non-empty cell lies in the 3x3x3 cells around the element's centre on one
 * level (render_cone_core.h), that is where the centre lies in the cube of 3 cells about a
 * non-empty cell's centre (render_cone.c, cone_light_end). */
#ifndef VX_SHADOW_CLIP_H
#define VX_SHADOW_CLIP_H

#include "grid_core.h"
#include "vec.h"

typedef struct {
    const voxel_grid *g; /* NULL: no map (shadow_clip_end leaves the ray's end alone) */
    int level;               /* the MIP level whose cells the map holds; its lattice units below */
    double u[3], v[3], w[3]; /* orthonormal; w along the direction toward the light */
    double u0, v0;           /* the map's corner, along u and v */
    double column;           /* a column's width (lattice units): a power of two */
    double per_column;       /* 1 / column (exact) */
    vec3 built_for;          /* the direction the map was built for, and its lattice speed along w */
    double speed;
    int nu, nv;
    float *reach; /* nu * nv, index iu * nv + iv: the largest w over the column's voxels; -INFINITY: none */
} shadow_clip;

/* The map of grid g for shadow rays along to_light (a directional light's unit direction toward
 * it). Returns 0, or -1 when out of memory (c->g NULL then). */
int shadow_clip_build(shadow_clip *c, const voxel_grid *g, vec3 to_light);
/* The map of the non-empty cells of `level`, each taken as the cube of edge `side` (in the level's
 * cells; 1: the cell itself) about its centre, every face pushed out by `slack` more (cells; 0 for
 * walks from the same lattice point as the map's queries; more for positions rounded apart from it).
 * shadow_clip_build is level 0, side 1, slack 0. */
int shadow_clip_build_cells(shadow_clip *c, const voxel_grid *g, int level, double side, double slack, vec3 to_light);

/* The light cones' maps: every cell's 3x3x3 neighbourhood (edge 3), and this slack (cells of the
 * map's level) for the rounding of the cones' float positions (render_cone.c). */
#define SHADOW_CLIP_CONE_SIDE 3.0
#define SHADOW_CLIP_CONE_SLACK 0.125
void shadow_clip_free(shadow_clip *c);
size_t shadow_clip_bytes(const shadow_clip *c);

/* The end for the shadow ray p + t * to_light (to_light: the direction the map was built for) that
 * would otherwise end at t_max: no non-empty voxel lies on the ray beyond the returned t. A value
 * not above the ray's start means that nothing lies on it at all. */
float shadow_clip_end(const shadow_clip *c, vec3 p, vec3 to_light, float t_max);
/* The same with p already in level-0 lattice units (gt_lattice_point), as the shadow ray's walk
 * maps it: one mapping for both (whatever level the map is of). */
float shadow_clip_end_lattice(const shadow_clip *c, const double o[3], vec3 to_light, float t_max);

#endif
