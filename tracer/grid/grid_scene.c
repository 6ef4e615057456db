/* grid_build_scene (grid_scene.h). */
#include "grid_scene.h"

#include "scene_tris.h"

static void scene_corners(const void *ctx, size_t first, size_t n, float (*out)[9])
{
    scene_triangle_corners(ctx, first, n, out);
}

int grid_build_scene(voxel_grid *g, const scene *s, int n, const double *blo, const double *bhi, vx_err *e)
{
    double lo[3], hi[3];
    scene_triangle_bounds(s, lo, hi);
    if (grid_take_lattice(lo, hi, blo, bhi, e))
        return -1;
    grid_triangles src = {scene_triangle_count(s), scene_corners, s};
    return grid_build_triangles(g, &src, n, lo, hi, 2, e);
}
