/* The C tracer's entry points of the DDA. The iterator itself is portable C in
 * grid_traverse_core.h, which the OpenCL backend compiles too: one implementation for both. */
#include "grid_traverse.h"

int grid_iter_init(grid_iter *it, const voxel_grid *g, int level, vec3 origin, vec3 dir, float t_min,
                   float t_max)
{
    return gt_iter_init(it, g, level, origin, dir, t_min, t_max);
}

int grid_iter_next(grid_iter *it, grid_hit *hit) { return gt_iter_next(it, hit); }
