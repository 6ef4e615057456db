/* The voxel grid as the host hands it to an OpenCL kernel: the mapping and, per level, where its
 * tables start in the concatenated cols / bits+prefix buffers (the bits buffer also holds the coarse
 * levels' plain bits, after the stored words). Shared by the voxel kernel's and the
 * cone kernel's parameter blocks (tracer/backends/opencl/cl/render_params.h, render_cone_params.h), filled by the
 * host (vx_cl_grid_params_fill) and turned back into a voxel_grid by the kernel
 * (vx_cl_grid_from_params), so that both kernels read the grid the same way. Only types C on
 * x86-64 and OpenCL C lay out alike (the programs check their parameter blocks' sizes). */
#ifndef VX_CL_GRID_PARAMS_H
#define VX_CL_GRID_PARAMS_H

#include "grid_core.h"

typedef struct {
    double origin_d[3]; /* the grid mapping (grid_core.h) */
    double voxel_size_d;
    uint64_t level_cols[GRID_MAX_LEVELS];  /* where each level's column table starts in the cols buffer */
    uint64_t level_words[GRID_MAX_LEVELS]; /* where each level's words start in the bits and prefix buffers */
    /* where each level's plain bits (grid_level.dense) start in the bits buffer, after every level's
     * stored words; VX_CL_NO_DENSE: the level has none */
    uint64_t level_dense[GRID_MAX_LEVELS];
    uint64_t level_count[GRID_MAX_LEVELS]; /* non-empty cells per level (the records' level offsets) */
    vec3 origin;
    float voxel_size;
    int n, levels;
    int level_n[GRID_MAX_LEVELS];
} vx_cl_grid_params;

#define VX_CL_NO_DENSE (~(uint64_t)0)

#ifdef __OPENCL_VERSION__
/* The grid as grid_core.h expects it, its level tables pointing into the buffers (the coordinates,
 * word counts and the levels past the last are not used by the lookups and the walks). */
static void vx_cl_grid_from_params(voxel_grid *g, __global const vx_cl_grid_params *P, __global ulong *cols,
                                   __global ulong *bits, __global uint *prefix)
{
    g->n = P->n;
    g->origin = P->origin;
    g->voxel_size = P->voxel_size;
    for (int a = 0; a < 3; a++)
        g->origin_d[a] = P->origin_d[a];
    g->voxel_size_d = P->voxel_size_d;
    g->levels = P->levels;
    for (int l = 0; l < P->levels; l++) {
        grid_level *L = &g->level[l];
        L->n = P->level_n[l];
        L->words_per_col = (L->n + 63) / 64;
        L->cols = cols + P->level_cols[l];
        L->bits = bits + P->level_words[l];
        L->prefix = prefix + P->level_words[l];
        L->coords = 0;
        L->dense = P->level_dense[l] == VX_CL_NO_DENSE ? 0 : bits + P->level_dense[l];
        L->words = 0;
        L->count = (size_t)P->level_count[l];
    }
}
#else
#include "grid.h"

/* The words of level l's plain bits, 0 when it keeps none. */
static inline uint64_t vx_cl_dense_words(const voxel_grid *g, int l)
{
    return g->level[l].dense ? (uint64_t)grid_dense_words(l, g->level[l].n) : 0;
}

/* The host side: the mapping and the level offsets, levels concatenated in order (as the backends
 * upload the tables: every level's stored words, then the plain bits of those that keep them). */
static inline void vx_cl_grid_params_fill(vx_cl_grid_params *p, const voxel_grid *g)
{
    uint64_t cols = 0, words = 0;
    for (int l = 0; l < g->levels; l++) {
        p->level_cols[l] = cols;
        p->level_words[l] = words;
        p->level_count[l] = g->level[l].count;
        p->level_n[l] = g->level[l].n;
        cols += (uint64_t)g->level[l].n * (uint64_t)g->level[l].n;
        words += g->level[l].words;
    }
    for (int l = 0; l < GRID_MAX_LEVELS; l++) {
        uint64_t dense = l < g->levels ? vx_cl_dense_words(g, l) : 0;
        p->level_dense[l] = dense ? words : VX_CL_NO_DENSE;
        words += dense;
    }
    for (int a = 0; a < 3; a++)
        p->origin_d[a] = g->origin_d[a];
    p->voxel_size_d = g->voxel_size_d;
    p->origin = g->origin;
    p->voxel_size = g->voxel_size;
    p->n = g->n;
    p->levels = g->levels;
}
#endif

#endif
