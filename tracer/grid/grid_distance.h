/* A chessboard distance field over one MIP level of a voxel_grid: per block, the distance in blocks
 * to the nearest non-empty block (0 for a non-empty one), capped at GRID_DISTANCE_CAP. So every
 * point within (D - 1) blocks (max norm) of a point of a block at distance D is empty: a ray can
 * jump that far without passing a non-empty voxel ("proximity clouds", Cohen & Sheffer 1994).
 *
 * Used by the C backend to skip empty space exactly before a pixel's primary rays start their DDA
 * (tracer/render/pixel_skip.h). (Jumping by it inside the DDA as well, once a walk is in a large
 * empty block, was tried for the shadow rays and made frames slower: the hierarchical DDA already
 * crosses large empty blocks in a few steps, and a jump's restart at single cells costs more.) The
 * level: the finest with at most GRID_DISTANCE_MAX_N blocks a side (n^3 bytes,
 * 262 KB at 64^3, built in a few milliseconds), fine enough that the jumps stop a few voxels from
 * surfaces. Host code only (the OpenCL kernels walk without it). */
#ifndef VX_GRID_DISTANCE_H
#define VX_GRID_DISTANCE_H

#include "grid_core.h"

#define GRID_DISTANCE_MAX_N 64
#define GRID_DISTANCE_CAP 32

typedef struct grid_distance {
    int level;           /* the MIP level whose blocks the field covers */
    int n;               /* blocks a side */
    double block;        /* a block's edge in world units */
    double lo[3], hi[3]; /* the grid's box in world units */
    unsigned char *dist; /* n^3, index (x * n + y) * n + z; NULL: no field */
} grid_distance;

/* Builds the field of g (an empty grid's is GRID_DISTANCE_CAP everywhere). Returns 0, or -1 when out
 * of memory (d->dist NULL). */
int grid_distance_build(grid_distance *d, const voxel_grid *g);
void grid_distance_free(grid_distance *d);

/* The distance of block (x, y, z) (inside the field). */
static inline int grid_distance_at(const grid_distance *d, int x, int y, int z)
{
    return d->dist[((size_t)x * (size_t)d->n + (size_t)y) * (size_t)d->n + (size_t)z];
}

#endif
