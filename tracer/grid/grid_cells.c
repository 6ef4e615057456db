/* A grid from the list of its level-0 cells in dense-index order (what a .vox file stores), built
 * sparse level by level: no N^3 bit array (128 MB at 1024^3) and no voxelisation, so that a render
 * of a baked file does not redo the bake's grid. The arrays come out byte for byte as grid.c's
 * compaction of the same cells writes them (tests/unit_grid.c compares them), including the first-word
 * field of empty columns. Also grid_build_cells (a moving object's frame, tracer/dynamic/): its cells
 * come in order too, and only a list out of order or with repeats goes through grid.c's bit array. */
#include "grid.h"

#include <string.h>

#include "grid_memory.h"

/* Packed coordinates (x << 20 | y << 10 | z): the numeric order is the (x, y, z) order. */
#define CELL_COLUMN(c) ((c) >> 10)  /* x << 10 | y */
#define CELL_WORD(c) ((c) >> 6)     /* the column and z / 64 */

static int alloc_level(grid_level *L, vx_err *e)
{
    L->bits = big_alloc(bits_bytes(L));
    L->prefix = big_alloc(prefix_bytes(L));
    L->coords = big_alloc(coords_bytes(L));
    if (!L->bits || !L->prefix || !L->coords)
        return vx_fail(e, "grid_build: out of memory for a %d^3 level (%zu voxels)", L->n, L->count);
    return 0;
}

/* Level 0 from the sorted, checked cells: each run of cells in one 64-cell word becomes a stored word. */
static int level_from_cells(grid_level *L, int n, const uint32_t *cells, size_t count, vx_err *e)
{
    L->n = n;
    L->words_per_col = (n + 63) / 64;
    L->count = count;
    L->words = 0;
    for (size_t i = 0; i < count; i++)
        L->words += i == 0 || CELL_WORD(cells[i]) != CELL_WORD(cells[i - 1]);
    L->cols = big_alloc(cols_bytes(L));
    if (!L->cols || alloc_level(L, e))
        return L->cols ? -1 : vx_fail(e, "grid_build: out of memory for a %d^3 level", n);
    memcpy(L->coords, cells, count * sizeof *cells);
    size_t ci = 0, wi = 0;
    for (uint32_t x = 0; x < (uint32_t)n; x++)
        for (uint32_t y = 0; y < (uint32_t)n; y++) {
            uint64_t first = wi, mask = 0;
            while (ci < count && CELL_COLUMN(cells[ci]) == (x << 10 | y)) {
                uint32_t word = CELL_WORD(cells[ci]);
                uint64_t bits = 0;
                L->prefix[wi] = (uint32_t)ci;
                for (; ci < count && CELL_WORD(cells[ci]) == word; ci++)
                    bits |= UINT64_C(1) << (cells[ci] & 63u);
                L->bits[wi++] = bits;
                mask |= UINT64_C(1) << ((word & 15u));
            }
            L->cols[(size_t)x * (size_t)n + y] = first << 16 | mask;
        }
    return 0;
}

/* The coarse column (X, Y)'s words from its (up to) 4 child columns: word j is child words 2j and
 * 2j + 1 halved along z (grid.c's downsample, over stored words only). Returns the mask of the
 * non-zero coarse words; out has 16 entries. */
static uint64_t coarse_column(const grid_level *C, int X, int Y, uint64_t out[16])
{
    uint64_t child[16] = {0};
    for (int s = 0; s < 4; s++) {
        int x = 2 * X + (s >> 1), y = 2 * Y + (s & 1);
        if (x >= C->n || y >= C->n)
            continue; /* a partial last block has fewer children */
        uint64_t col = C->cols[(size_t)x * (size_t)C->n + (size_t)y];
        size_t w = (size_t)(col >> 16);
        for (uint64_t m = col & 0xffffu; m; m &= m - 1)
            child[__builtin_ctzll(m)] |= C->bits[w++];
    }
    uint64_t mask = 0;
    for (int j = 0; j < 8; j++) {
        out[j] = halve_words(child[2 * j], child[2 * j + 1]);
        mask |= (uint64_t)(out[j] != 0) << j;
    }
    return mask;
}

/* Level L from its children C: a first pass counts the stored words and cells, the second fills them. */
static int level_from_children(grid_level *L, const grid_level *C, vx_err *e)
{
    int n = (C->n + 1) / 2;
    L->n = n;
    L->words_per_col = (n + 63) / 64;
    L->cols = big_alloc(cols_bytes(L));
    if (!L->cols)
        return vx_fail(e, "grid_build: out of memory for a %d^3 level", n);
    uint64_t w[16];
    L->words = 0;
    L->count = 0;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++) {
            uint64_t mask = coarse_column(C, x, y, w);
            L->cols[(size_t)x * (size_t)n + (size_t)y] = mask;
            for (uint64_t m = mask; m; m &= m - 1) {
                L->words++;
                L->count += (size_t)__builtin_popcountll(w[__builtin_ctzll(m)]);
            }
        }
    if (alloc_level(L, e))
        return -1;
    size_t wi = 0, c = 0;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++) {
            uint64_t *col = &L->cols[(size_t)x * (size_t)n + (size_t)y];
            uint64_t first = wi, mask = *col;
            if (mask)
                coarse_column(C, x, y, w);
            for (uint64_t m = mask; m; m &= m - 1) {
                int j = __builtin_ctzll(m);
                L->bits[wi] = w[j];
                L->prefix[wi++] = (uint32_t)c;
                uint32_t xyz = (uint32_t)x << 20 | (uint32_t)y << 10 | (uint32_t)(j * 64);
                for (uint64_t b = w[j]; b; b &= b - 1)
                    L->coords[c++] = xyz + (uint32_t)__builtin_ctzll(b);
            }
            *col = first << 16 | mask;
        }
    return 0;
}

/* Every level of g (its n, levels and mapping set) from level 0's cells, listed once each in order
 * and inside the grid (the caller checked). On error g is freed. */
static int levels_from_sorted_cells(voxel_grid *g, const uint32_t *cells, size_t count, vx_err *e)
{
    int rc = level_from_cells(&g->level[0], g->n, cells, count, e);
    for (int l = 1; rc == 0 && l < g->levels; l++)
        rc = (level_from_children(&g->level[l], &g->level[l - 1], e) || level_fill_dense(&g->level[l], l, e)) ? -1 : 0;
    if (rc)
        grid_free(g);
    return rc;
}

int grid_build_sorted_cells(voxel_grid *g, int n, const double lo[3], const double hi[3], const uint32_t *cells,
                            size_t count, vx_err *e)
{
    memset(g, 0, sizeof *g);
    if (n < 1 || n > GRID_MAX_N)
        return vx_fail(e, "grid_build: resolution %d is outside 1..%d", n, GRID_MAX_N);
    for (size_t i = 0; i < count; i++) {
        uint32_t c = cells[i];
        int x = (int)(c >> 20), y = (int)((c >> 10) & 1023u), z = (int)(c & 1023u);
        if (x >= n || y >= n || z >= n)
            return vx_fail(e, "cell %zu, (%d, %d, %d), is outside the %d^3 grid", i, x, y, z, n);
        if (i > 0 && c <= cells[i - 1])
            return vx_fail(e, "cell %zu, (%d, %d, %d), does not follow cell %zu: cells are listed once each, in "
                              "(x, y, z) order",
                           i, x, y, z, i - 1);
    }
    grid_set_mapping(g, n, lo, hi);
    return levels_from_sorted_cells(g, cells, count, e);
}

int grid_build_cells(voxel_grid *g, const voxel_grid *like, const uint32_t *cells, size_t count, vx_err *e)
{
    memset(g, 0, sizeof *g);
    g->n = like->n;
    memcpy(g->origin_d, like->origin_d, sizeof g->origin_d);
    g->voxel_size_d = like->voxel_size_d;
    g->origin = like->origin;
    g->voxel_size = like->voxel_size;
    g->levels = like->levels;
    int sorted = 1;
    for (size_t i = 0; i < count; i++) {
        int x = (int)(cells[i] >> 20), y = (int)((cells[i] >> 10) & 1023u), z = (int)(cells[i] & 1023u);
        if (x >= g->n || y >= g->n || z >= g->n) {
            memset(g, 0, sizeof *g);
            return vx_fail(e, "grid_build: cell (%d, %d, %d) outside the %d^3 grid", x, y, z, g->n);
        }
        sorted &= i == 0 || cells[i] > cells[i - 1];
    }
    /* Listed once each in order (what tracer/dynamic/ hands over: its pieces are sorted by cell):
     * built sparse, without the n^3 bit array (128 MB a frame at 1024^3). Otherwise through that
     * array (grid.c). The arrays are the same either way (tests/unit_grid.c). */
    if (sorted)
        return levels_from_sorted_cells(g, cells, count, e);
    return grid_build_dense_cells(g, cells, count, e);
}
