/* Inside the grid builders (grid.c from triangles, grid_cells.c from a list of cells): how a sparse
 * level's arrays are allocated and sized, the bit trick that halves a column, the coarse levels'
 * plain bits and the mapping.
 * Not for the grid's users: they read grid.h. */
#ifndef VX_GRID_MEMORY_H
#define VX_GRID_MEMORY_H

#include <stdint.h>
#include <stdlib.h>
#include <sys/mman.h>

#include "grid.h"

/* The even bits of x, packed into the low 32 bits (bit 2k -> bit k). */
static inline uint64_t even_bits(uint64_t x)
{
    x &= UINT64_C(0x5555555555555555);
    x = (x | (x >> 1)) & UINT64_C(0x3333333333333333);
    x = (x | (x >> 2)) & UINT64_C(0x0f0f0f0f0f0f0f0f);
    x = (x | (x >> 4)) & UINT64_C(0x00ff00ff00ff00ff);
    x = (x | (x >> 8)) & UINT64_C(0x0000ffff0000ffff);
    x = (x | (x >> 16)) & UINT64_C(0x00000000ffffffff);
    return x;
}

/* A coarse word from child words a (cells 0..63 of the pair) and b (64..127): a coarse cell is set
 * when either of its two children along z is. */
static inline uint64_t halve_words(uint64_t a, uint64_t b)
{
    return even_bits(a | (a >> 1)) | (even_bits(b | (b >> 1)) << 32);
}

/* Zeroed memory. Large blocks are mapped with MAP_POPULATE: first-touch page faults cost ~11 us a
 * page on the VMs this runs on, so a fresh 16 MiB array (512^3 bits) took ~45 ms to fault in, as
 * long as voxelising the bunny, against ~3 ms to populate the mapping in one call. Whether a block
 * is mapped depends only on its size, so big_free needs no flag. */
#define BIG_BYTES ((size_t)1 << 20)

static inline void *big_alloc(size_t bytes)
{
#ifdef MAP_POPULATE
    if (bytes >= BIG_BYTES) {
        void *p = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_POPULATE, -1, 0);
        return p == MAP_FAILED ? NULL : p;
    }
#endif
    return calloc(1, bytes ? bytes : 1);
}

static inline void big_free(void *p, size_t bytes)
{
    if (!p)
        return;
#ifdef MAP_POPULATE
    if (bytes >= BIG_BYTES) {
        munmap(p, bytes);
        return;
    }
#endif
    free(p);
}

/* Sizes of a sparse level's arrays (+1 entry so that an empty level still gets non-NULL arrays). */
static inline size_t cols_bytes(const grid_level *L) { return (size_t)L->n * (size_t)L->n * sizeof *L->cols; }
static inline size_t bits_bytes(const grid_level *L) { return (L->words + 1) * sizeof *L->bits; }
static inline size_t prefix_bytes(const grid_level *L) { return (L->words + 1) * sizeof *L->prefix; }
static inline size_t coords_bytes(const grid_level *L) { return (L->count + 1) * sizeof *L->coords; }

/* Bytes of level `level`'s plain bits (grid_level.dense; grid.h's grid_dense_words), 0 where it keeps none. */
static inline size_t dense_bytes(const grid_level *L, int level)
{
    return grid_dense_words(level, L->n) * sizeof *L->dense;
}

/* Level `level`'s plain bits from its sparse form (complete), where it keeps them: each stored word
 * copied to its place in its column. 0, or -1 when out of memory. */
static inline int level_fill_dense(grid_level *L, int level, vx_err *e)
{
    L->dense = NULL;
    if (!dense_bytes(L, level))
        return 0;
    L->dense = big_alloc(dense_bytes(L, level));
    if (!L->dense)
        return vx_fail(e, "grid_build: out of memory for a %d^3 level's bits", L->n);
    for (size_t c = 0; c < (size_t)L->n * (size_t)L->n; c++) {
        size_t w = (size_t)(L->cols[c] >> 16);
        for (uint64_t m = L->cols[c] & 0xffffu; m; m &= m - 1)
            L->dense[c * (size_t)L->words_per_col + (size_t)__builtin_ctzll(m)] = L->bits[w++];
    }
    return 0;
}

/* The mapping documented in grid.h for n cells a side over bounds lo/hi, and the level count. */
void grid_set_mapping(voxel_grid *g, int n, const double lo[3], const double hi[3]);

/* Every level of g (its n, levels and mapping set, its arrays not yet) from level 0's cells, inside
 * the grid (the caller checked), in any order and repeated or not: grid.c's compaction of an n^3
 * bit array. On error g is zeroed. */
int grid_build_dense_cells(voxel_grid *g, const uint32_t *cells, size_t count, vx_err *e);

#endif
