/* The chessboard distance field of a grid's MIP level (see grid_distance.h). */
#include "grid_distance.h"

#include <stdlib.h>
#include <string.h>

/* The finest level with at most GRID_DISTANCE_MAX_N blocks a side: small enough to build in a few
 * milliseconds and to stay in cache, fine enough that the walk stops a few voxels from surfaces. */
static int skip_level(const voxel_grid *g)
{
    for (int k = 0; k < g->levels; k++)
        if (g->level[k].n <= GRID_DISTANCE_MAX_N)
            return k;
    return g->levels - 1;
}

/* One erosion of the empty mask along an axis (3 wide; outside the grid counts as empty), written
 * as AND-ing whole z rows so that the compiler vectorises it (the build then takes a millisecond or
 * two at 64^3 instead of tens). */
static void erode(unsigned char *restrict dst, const unsigned char *restrict src, int n, int axis)
{
    size_t nn = (size_t)n;
    if (axis == 2) {
        for (size_t row = 0; row < nn * nn; row++) {
            const unsigned char *a = src + row * nn;
            unsigned char *b = dst + row * nn;
            b[0] = n > 1 ? (unsigned char)(a[0] & a[1]) : a[0];
            for (size_t z = 1; z + 1 < nn; z++)
                b[z] = a[z - 1] & a[z] & a[z + 1];
            if (n > 1)
                b[nn - 1] = a[nn - 2] & a[nn - 1];
        }
        return;
    }
    /* Along x (axis 0) or y (axis 1): a row's neighbours are whole rows `stride` bytes away. */
    size_t stride = axis == 0 ? nn * nn : nn;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++) {
            int c = axis == 0 ? x : y;
            size_t i = ((size_t)x * nn + (size_t)y) * nn;
            const unsigned char *a = src + i, *lo = c > 0 ? a - stride : a, *hi = c < n - 1 ? a + stride : a;
            unsigned char *b = dst + i;
            for (size_t z = 0; z < nn; z++)
                b[z] = lo[z] & a[z] & hi[z];
        }
}

int grid_distance_build(grid_distance *s, const voxel_grid *g)
{
    memset(s, 0, sizeof *s);
    if (!g || g->levels < 1)
        return 0;
    int k = skip_level(g);
    const grid_level *L = &g->level[k];
    int n = L->n;
    size_t count = (size_t)n * (size_t)n * (size_t)n;
    unsigned char *mask = malloc(count), *tmp = malloc(count);
    s->dist = malloc(count);
    if (!mask || !tmp || !s->dist) {
        free(mask);
        free(tmp);
        grid_distance_free(s);
        return -1;
    }
    s->level = k;
    s->n = n;
    s->block = g->voxel_size_d * (double)(1 << k);
    for (int a = 0; a < 3; a++) {
        s->lo[a] = g->origin_d[a];
        s->hi[a] = g->origin_d[a] + (double)g->n * g->voxel_size_d;
    }
    /* Chessboard distance D to the nearest non-empty block: D >= d + 1 exactly where the cube of
     * half-width d blocks around the block is empty, i.e. the block survives d erosions of the empty
     * set by the 3x3x3 cube (separable: three 3-wide erosions, one per axis). */
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++)
            for (int z = 0; z < n; z++) {
                size_t i = ((size_t)x * (size_t)n + (size_t)y) * (size_t)n + (size_t)z;
                mask[i] = !grid_level_occupied(L, x, y, z);
                s->dist[i] = mask[i];
            }
    for (int d = 1; d < GRID_DISTANCE_CAP; d++) {
        erode(tmp, mask, n, 0);
        erode(mask, tmp, n, 1);
        erode(tmp, mask, n, 2);
        unsigned char *eroded = tmp; /* the result is in tmp: the buffers trade places */
        tmp = mask;
        mask = eroded;
        int any = 0;
        for (size_t i = 0; i < count; i++) {
            s->dist[i] = (unsigned char)(s->dist[i] + mask[i]);
            any |= mask[i];
        }
        if (!any)
            break;
    }
    free(mask);
    free(tmp);
    return 0;
}

void grid_distance_free(grid_distance *s)
{
    free(s->dist);
    s->dist = NULL;
}

