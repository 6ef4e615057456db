/* The portable part of the sparse voxel grid (layout and mapping documented in grid.h): its types
 * and the O(1) cell lookups. Plain C with no libc beyond <math.h>, so the OpenCL backend compiles
 * this same file as OpenCL C (tracer/backends/opencl/cl/render.cl): there the arrays live in __global memory and the
 * level tables are rebuilt per work-item from buffer offsets, but every lookup is the code below.
 *
 * OpenCL C needs the includer to have enabled cl_khr_fp64 (the mapping is in double) and to
 * provide the fixed-width integer names (tracer/backends/opencl/cl/prelude.h does). */
#ifndef VX_GRID_CORE_H
#define VX_GRID_CORE_H

#include "vec.h"

#ifdef __OPENCL_VERSION__
#define VX_GLOBAL __global
#define VX_POPCOUNT32(x) popcount((uint)(x))
#define VX_POPCOUNT64(x) popcount((ulong)(x))
#else
#include <stddef.h>
#include <stdint.h>
#define VX_GLOBAL
#define VX_POPCOUNT32(x) __builtin_popcount(x)
#define VX_POPCOUNT64(x) __builtin_popcountll(x)
#endif

#define GRID_MAX_N 1024
#define GRID_MAX_LEVELS 11 /* 1024, 512, ..., 1 */

typedef struct {
    int n;             /* cells per side: ceil(grid n / 2^level) */
    int words_per_col; /* ceil(n / 64) */
    VX_GLOBAL uint64_t *cols;   /* n*n, index x*n + y: (first stored word << 16) | mask of non-zero words */
    VX_GLOBAL uint64_t *bits;   /* stored (non-zero) words, bit z%64 of word z/64 of its column */
    VX_GLOBAL uint32_t *prefix; /* per stored word: non-empty cells in all earlier stored words */
    VX_GLOBAL uint32_t *coords; /* per non-empty cell, by dense index: x << 20 | y << 10 | z */
    size_t words;      /* stored words */
    size_t count;      /* non-empty cells */
    /* The level's occupancy as plain bits as well, column by column: bit z % 64 of word
     * (x n + y) words_per_col + z / 64. Only for the coarse levels (1 and up) small enough
     * (grid.h's GRID_DENSE_MAX_BYTES), whose lookups are the walks' emptiness tests: one load
     * where the sparse form takes two dependent ones and a popcount. NULL elsewhere: level 0, whose
     * lookups want the dense index anyway, and the levels too large. The OpenCL kernels get them in
     * their bits buffer (tracer/backends/opencl/cl/grid_params.h). */
    VX_GLOBAL uint64_t *dense;
} grid_level;

typedef struct voxel_grid {
    int n;              /* cells per side at level 0 */
    vec3 origin;        /* float copy of origin_d (for display; the exact mapping is origin_d) */
    float voxel_size;   /* float copy of voxel_size_d */
    double origin_d[3]; /* the mapping used by the build and the traversal */
    double voxel_size_d;
    int levels;         /* level 0 (n) to levels-1 (1 cell) */
    grid_level level[GRID_MAX_LEVELS];
} voxel_grid;

/* Dense index of a cell known to be inside the level (no range checks), -1 when empty. */
VX_INLINE int64_t grid_level_index(const grid_level *L, int x, int y, int z)
{
    uint64_t col = L->cols[(size_t)x * (size_t)L->n + (size_t)y];
    unsigned j = (unsigned)z >> 6, b = (unsigned)z & 63u;
    uint32_t mask = (uint32_t)(col & 0xffffu);
    if (!((mask >> j) & 1u))
        return -1;
    size_t w = (size_t)(col >> 16) + (size_t)VX_POPCOUNT32(mask & ((1u << j) - 1u));
    uint64_t bits = L->bits[w];
    if (!((bits >> b) & 1u))
        return -1;
    return (int64_t)L->prefix[w] + (int64_t)VX_POPCOUNT64(bits & ((((uint64_t)1) << b) - 1u));
}

/* Whether a cell known to be inside the level is non-empty: from the plain bits when the level keeps
 * them, else the index without the prefix load. */
VX_INLINE int grid_level_occupied(const grid_level *L, int x, int y, int z)
{
    if (L->dense) {
        size_t w = ((size_t)x * (size_t)L->n + (size_t)y) * (size_t)L->words_per_col + ((unsigned)z >> 6);
        return (int)((L->dense[w] >> ((unsigned)z & 63u)) & 1u);
    }
    uint64_t col = L->cols[(size_t)x * (size_t)L->n + (size_t)y];
    unsigned j = (unsigned)z >> 6;
    uint32_t mask = (uint32_t)(col & 0xffffu);
    if (!((mask >> j) & 1u))
        return 0;
    size_t w = (size_t)(col >> 16) + (size_t)VX_POPCOUNT32(mask & ((1u << j) - 1u));
    return (int)((L->bits[w] >> ((unsigned)z & 63u)) & 1u);
}

/* A world-space point in level-0 lattice units (double: exact enough far from the origin). */
VX_INLINE void grid_to_lattice(const voxel_grid *g, vec3 p, double out[3])
{
    out[0] = ((double)p.x - g->origin_d[0]) / g->voxel_size_d;
    out[1] = ((double)p.y - g->origin_d[1]) / g->voxel_size_d;
    out[2] = ((double)p.z - g->origin_d[2]) / g->voxel_size_d;
}

/* Dense index of cell (x, y, z) of `level`, -1 when the cell is empty or outside the grid. */
VX_INLINE int64_t grid_index(const voxel_grid *g, int level, int x, int y, int z)
{
    if (level < 0 || level >= g->levels)
        return -1;
    const grid_level *L = &g->level[level];
    if ((unsigned)x >= (unsigned)L->n || (unsigned)y >= (unsigned)L->n || (unsigned)z >= (unsigned)L->n)
        return -1;
    return grid_level_index(L, x, y, z);
}

/* World-space corners of a cell of `level`: both backends call this, so they hand models
 * bit-identical voxel corners. */
VX_INLINE void grid_cell_corners(const voxel_grid *g, int level, int x, int y, int z, vec3 *lo, vec3 *hi)
{
    double s = ldexp(g->voxel_size_d, level);
    const double *o = g->origin_d;
    *lo = v3((float)(o[0] + x * s), (float)(o[1] + y * s), (float)(o[2] + z * s));
    *hi = v3((float)(o[0] + (x + 1) * s), (float)(o[1] + (y + 1) * s), (float)(o[2] + (z + 1) * s));
}

#endif
