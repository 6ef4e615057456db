/* A sparse voxel grid over a triangle mesh: which cells of an N^3 lattice the surface touches
 * (exact triangle/box overlap, touching counts), with a dense index 0..count-1 for every non-empty
 * cell so that models keep per-voxel data in plain arrays of length count, and a MIP hierarchy
 * (level l has ceil(N / 2^l) cells a side, a cell non-empty when any of its 8 children is).
 *
 * Grid mapping (tests and models depend on it; computed in double, see grid_build):
 *   lo, hi    = component-wise min / max over the vertices of all triangles
 *   extent    = max over axes of (hi - lo)    (when 0, a tiny positive extent is substituted)
 *   pad       = min(1.5, N / 4) cells         (1.5 for every N >= 6)
 *   voxel_size = extent / (N - 2 * pad)       (= extent / (N - 3) for N >= 6)
 *   origin    = lo - pad * voxel_size         (on every axis: the grid starts 1.5 cells below the
 *                                              scene on x, y and z and is not centred)
 *   level-0 cell (x, y, z) is the closed box origin + [x, x+1] * voxel_size (per axis), likewise
 *   level-l cell (x, y, z) is origin + [x, x+1] * voxel_size * 2^l.
 * So the scene's minimum faces on every axis, and its maximum face on the largest axis, lie on
 * cell centres (1.5 and N - 1.5): a wall or ground plate on the scene bounds makes one layer of
 * voxels, not two, and at least one empty cell surrounds everything (for N >= 6).
 *
 * Storage per level (in the spirit of the slicemap's bit-packed columns): occupancy is kept as
 * 64-cell words along z. Only non-zero words are stored; a table with one entry per (x, y) column
 * holds a 16-bit mask of the column's non-zero words (N <= 1024 means at most 16 words) and the
 * position of its first stored word. Each stored word has a prefix count (set bits in all earlier
 * stored words), so a cell's dense index is prefix + popcount(bits below it): O(1), 3 loads.
 * Memory is 8 bytes per column (N^2) + 12 bytes per non-zero word + 4 bytes per non-empty voxel
 * (its packed coordinates), instead of N^3/8 bytes of bits: it grows with the surface, not the
 * volume. Dense indices follow (x, y, z) lexicographic order. The coarse levels (1 and up) whose
 * columns' words fit in GRID_DENSE_MAX_BYTES are kept as plain bits too (grid_level.dense), for the
 * walks' emptiness tests.
 *
 * A built grid is read-only, so any number of threads may query and traverse it. */
#ifndef VX_GRID_H
#define VX_GRID_H

#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "grid_core.h" /* the types, the cell lookups and the lattice mapping, portable C shared with OpenCL */
#include "mesh.h"
#include "vec.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The most a coarse level's plain bits take, n^2 ceil(n / 64) words (2 MiB: every coarse level of a
 * 256^3 grid, 306 kB in all; from level 1 of a 512^3 one, 2.4 MB; from level 2 of a 1024^3 one). */
#define GRID_DENSE_MAX_BYTES ((size_t)2 << 20)

/* The words of the plain bits (grid_level.dense) of level `level`, n cells a side: n^2 ceil(n / 64)
 * where the level keeps them (1 and up, at most GRID_DENSE_MAX_BYTES), else 0. The one rule the
 * builders, the OpenCL upload and the memory estimate follow. */
static inline size_t grid_dense_words(int level, int n)
{
    size_t words = (size_t)n * (size_t)n * (size_t)((n + 63) / 64);
    return level > 0 && words * sizeof(uint64_t) <= GRID_DENSE_MAX_BYTES ? words : 0;
}

/* Voxelises every triangle of m into an n^3 grid (mapping above) and builds all MIP levels, with
 * 2 threads. Errors (g is then zeroed): n outside 1..GRID_MAX_N, a mesh without triangles, a vertex
 * index out of range, non-finite coordinates. Zero-area triangles are skipped (they have no surface;
 * they still count for the bounds). The result does not depend on the thread count. */
int grid_build(voxel_grid *g, const mesh *m, int n, vx_err *e);
/* Same with an explicit thread count (>= 1), for benchmarks and determinism tests. */
int grid_build_threads(voxel_grid *g, const mesh *m, int n, int threads, vx_err *e);
/* Same over the lattice of explicit bounds lo/hi (containing the mesh) instead of the mesh's own:
 * an animated scene's frames share the lattice of the whole animation's bounds. */
int grid_build_bounds(voxel_grid *g, const mesh *m, int n, const double lo[3], const double hi[3], vx_err *e);
/* A grid with the mapping of `like` whose level-0 cells are the `count` packed coordinates
 * (x << 20 | y << 10 | z, as grid_coords reads them), in any order and repeated or not, MIP levels as
 * grid_build: moving objects' records put into the world lattice (tracer/dynamic/). Cells listed
 * once each in order are built sparse (grid_build_sorted_cells' way), others through an n^3 bit
 * array; the grid is the same. */
int grid_build_cells(voxel_grid *g, const voxel_grid *like, const uint32_t *cells, size_t count, vx_err *e);
/* The grid over bounds lo/hi (the mapping above) whose level-0 cells are the `count` packed
 * coordinates `cells`, listed once each in dense-index order (as grid_level.coords holds them): a
 * baked .vox file's grid, rebuilt without voxelising and without an n^3 bit array. The arrays are
 * those grid_build writes for the same cells. Errors: n outside 1..GRID_MAX_N, a cell outside the
 * grid or out of order (the message names it and starts with "cell", for the caller to prefix). */
int grid_build_sorted_cells(voxel_grid *g, int n, const double lo[3], const double hi[3], const uint32_t *cells,
                            size_t count, vx_err *e);
/* Triangles from any source, in batches: corners(ctx, first, n, out) writes the world corners of
 * triangles first .. first + n - 1 (x, y, z of corners 0, 1, 2). An instanced scene's copies are
 * placed on the fly this way, never written out (tracer/scene/scene_tris.h). */
typedef struct {
    size_t count;
    void (*corners)(const void *ctx, size_t first, size_t n, float (*out)[9]);
    const void *ctx;
} grid_triangles;
/* The grid of src's triangles over the lattice of bounds lo/hi (which must contain them; the
 * caller validated their coordinates), with `threads` threads. */
int grid_build_triangles(voxel_grid *g, const grid_triangles *src, int n, const double lo[3], const double hi[3],
                         int threads, vx_err *e);
/* The lattice a grid is built over: the triangles' bounds lo/hi, or, when blo/bhi are given (an
 * animation's shared lattice), those, which must contain lo/hi (else an error naming the axis). */
int grid_take_lattice(double lo[3], double hi[3], const double *blo, const double *bhi, vx_err *e);
void grid_free(voxel_grid *g);

/* Bytes allocated by the grid (all levels, tables, coordinates). */
size_t grid_bytes(const voxel_grid *g);

/* World-space centre of a cell of `level` (its corners: grid_core.h's grid_cell_corners). */
vec3 grid_cell_center(const voxel_grid *g, int level, int x, int y, int z);

VX_INLINE size_t grid_count(const voxel_grid *g, int level)
{
    return level >= 0 && level < g->levels ? g->level[level].count : 0;
}

/* Coordinates of the non-empty cell with dense index `index` (< grid_count) of `level`. */
VX_INLINE void grid_coords(const voxel_grid *g, int level, size_t index, int *x, int *y, int *z)
{
    uint32_t c = g->level[level].coords[index];
    *x = (int)(c >> 20);
    *y = (int)((c >> 10) & 1023u);
    *z = (int)(c & 1023u);
}

#ifdef __cplusplus
}
#endif

#endif
