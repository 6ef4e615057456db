/* Empty-space skipping for the cone marcher: per MIP level, a dense bitmap of the cells whose 3x3x3
 * neighbourhood holds a non-empty cell (the grid's occupancy dilated by one cell).
 *
 * Why: the cone marcher asks, for most elements, whether the neighbourhood of a cell is empty (then
 * no element in it has a non-empty interpolation stencil, and it jumps out of the cell). Asked of
 * the sparse grid that is 9 column lookups; the dilated bitmap answers with one bit. The bitmap
 * covers one cell beyond the grid on every side (those cells can have non-empty neighbours) and
 * costs n^3 / 8 bytes per level, so it is kept only for levels up to DILATED_MAX_N cells a side;
 * the marcher asks the sparse grid for the others.
 *
 * The lookup is portable C (the OpenCL cone kernel reads the same bitmaps from a buffer, all
 * levels concatenated); building them is host code (cone_skip.c). */
#ifndef VX_CONE_SKIP_H
#define VX_CONE_SKIP_H

#include "grid_core.h"

#define DILATED_MAX_N 640 /* 640^3 / 8 bytes = 33 MB: a 1024^3 grid keeps levels 1 and up */

typedef struct {
    int n;       /* cells a side of the bitmap: the level's n + 2 (offset by one) */
    int wpc;     /* 64-bit words per (x, y) column: ceil(n / 64) */
    VX_GLOBAL uint64_t *w; /* n * n * wpc words; NULL: no bitmap for this level */
} dilated_level;

typedef struct {
    dilated_level level[GRID_MAX_LEVELS];
} dilated_grid;

/* Whether the bitmap of `level` exists. */
VX_INLINE int dilated_has(const dilated_grid *d, int level)
{
    return d->level[level].w != 0;
}

/* Whether cell (x, y, z) of `level` (level coordinates, may lie outside the grid) has a non-empty
 * cell in its 3x3x3 neighbourhood. Only for a level with a bitmap. */
VX_INLINE int dilated_any(const dilated_grid *d, int level, int x, int y, int z)
{
    const dilated_level *D = &d->level[level];
    unsigned n = (unsigned)D->n, ux = (unsigned)(x + 1), uy = (unsigned)(y + 1), uz = (unsigned)(z + 1);
    if (ux >= n || uy >= n || uz >= n)
        return 0;
    return (int)((D->w[((size_t)ux * n + uy) * (size_t)D->wpc + (uz >> 6)] >> (uz & 63u)) & 1u);
}

#ifndef __OPENCL_VERSION__
/* Builds the bitmaps of g's levels (those small enough). Returns 0, or -1 when out of memory. */
int dilated_build(dilated_grid *d, const voxel_grid *g);
void dilated_free(dilated_grid *d);
/* Words of level l's bitmap (0 without one). */
size_t dilated_words(const dilated_grid *d, int level);
#endif

#endif
