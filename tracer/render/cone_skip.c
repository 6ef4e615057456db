/* Dilated occupancy bitmaps for the cone marcher's empty-space skipping (see cone_skip.h). */
#include "cone_skip.h"

#include <stdlib.h>
#include <string.h>

/* One level: each column's occupancy words (dense along z, shifted by one cell), dilated by one
 * cell along z, then OR-ed into the 3x3 columns around it. */
static int build_level(dilated_level *D, const grid_level *L)
{
    int n = L->n, dn = n + 2, wpc = (dn + 63) / 64;
    D->n = dn;
    D->wpc = wpc;
    D->w = calloc((size_t)dn * (size_t)dn * (size_t)wpc, sizeof *D->w);
    uint64_t *col = calloc((size_t)wpc, sizeof *col);
    if (!D->w || !col) {
        free(col);
        return -1;
    }
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++) {
            uint64_t c = L->cols[(size_t)x * (size_t)n + (size_t)y];
            uint32_t mask = (uint32_t)(c & 0xffffu);
            if (!mask)
                continue;
            /* The column's cells at z + 1 (the bitmap's offset). */
            memset(col, 0, (size_t)wpc * sizeof *col);
            size_t stored = (size_t)(c >> 16);
            for (int j = 0; j < 16; j++) {
                if (!((mask >> j) & 1u))
                    continue;
                uint64_t bits = L->bits[stored++];
                col[j] |= bits << 1;
                if (j + 1 < wpc)
                    col[j + 1] |= bits >> 63;
            }
            /* Dilate along z: a cell is marked when it or a z-neighbour is occupied. */
            uint64_t prev_top = 0;
            for (int k = 0; k < wpc; k++) {
                uint64_t w = col[k], next_low = k + 1 < wpc ? col[k + 1] & 1u : 0u;
                col[k] = w | (w << 1) | (w >> 1) | prev_top | (next_low << 63);
                prev_top = w >> 63;
            }
            for (int dx = 0; dx <= 2; dx++)
                for (int dy = 0; dy <= 2; dy++) {
                    uint64_t *dst = &D->w[((size_t)(x + dx) * (size_t)dn + (size_t)(y + dy)) * (size_t)wpc];
                    for (int k = 0; k < wpc; k++)
                        dst[k] |= col[k];
                }
        }
    free(col);
    return 0;
}

int dilated_build(dilated_grid *d, const voxel_grid *g)
{
    memset(d, 0, sizeof *d);
    for (int l = 0; l < g->levels; l++) {
        if (g->level[l].n > DILATED_MAX_N)
            continue;
        if (build_level(&d->level[l], &g->level[l])) {
            dilated_free(d);
            return -1;
        }
    }
    return 0;
}

void dilated_free(dilated_grid *d)
{
    for (int l = 0; l < GRID_MAX_LEVELS; l++)
        free(d->level[l].w);
    memset(d, 0, sizeof *d);
}

size_t dilated_words(const dilated_grid *d, int level)
{
    const dilated_level *D = &d->level[level];
    return D->w ? (size_t)D->n * (size_t)D->n * (size_t)D->wpc : 0;
}
