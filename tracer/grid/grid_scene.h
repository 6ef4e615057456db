/* The grid of a whole scene: the mesh's triangles and every instance copy's, placed on the fly
 * (tracer/scene/scene_tris.h), so an instanced scene is voxelised without being written out and
 * gives the grid its expanded form gives, cell for cell. */
#ifndef VX_GRID_SCENE_H
#define VX_GRID_SCENE_H

#include "grid.h"
#include "scene.h"

/* Over the scene's own bounds, or (lo, hi non-NULL) over a given lattice containing it, as an
 * animation's frames share one; 2 threads. */
int grid_build_scene(voxel_grid *g, const scene *s, int n, const double *lo, const double *hi, vx_err *e);

#endif
