/* Building the sparse voxel grid: bounds and mapping, exact voxelisation of the triangles into a
 * temporary dense bit array (2 threads), MIP levels by OR-ing children, and compaction of each level
 * into the sparse column form described in grid.h. */
#include "grid.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "grid_memory.h"
#include "tribox.h"

/* Triangles handed to a thread at a time: small enough to balance a mesh whose few huge triangles
 * (ground plates) sit in one place, large enough that the shared counter is not contended. */
#define BUILD_CHUNK 64

/* Dense occupancy bits of one level, used only while building. Words of 64 cells along z, grouped
 * in bricks of 4x4 columns (16 words, two cache lines): a triangle of a few cells touches one to
 * four bricks instead of a cache line per column, and a parent's 4 child columns share a brick.
 * Columns past n (brick padding) stay zero. */
typedef struct {
    uint64_t *w;
    size_t bytes;
    int n, W, bt; /* cells a side, words per column, bricks a side */
} dense_bits;

static inline size_t dense_word(const dense_bits *d, int x, int y, int j)
{
    size_t brick = ((size_t)(x >> 2) * (size_t)d->bt + (size_t)(y >> 2)) * (size_t)d->W + (size_t)j;
    return brick << 4 | (size_t)((x & 3) << 2 | (y & 3));
}

typedef struct {
    const grid_triangles *src;
    double origin[3], voxel_size;
    dense_bits *bits; /* level 0 */
    size_t next;      /* first triangle not yet handed out (atomic) */
} build_job;

/* OR m into *w. Both threads write the same array; the relaxed load first skips the locked
 * instruction in the common case where neighbouring triangles already set the bits. OR commutes,
 * so the result does not depend on the order the threads get there. */
static inline void set_bits(uint64_t *w, uint64_t m)
{
    if ((__atomic_load_n(w, __ATOMIC_RELAXED) & m) != m)
        __atomic_fetch_or(w, m, __ATOMIC_RELAXED);
}

static inline int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }
/* Plain comparisons: libm's fmin/fmax are not inlined (NaN rules) and the inputs here are finite. */
static inline double dmin(double a, double b) { return a < b ? a : b; }
static inline double dmax(double a, double b) { return a > b ? a : b; }

/* Marks every cell the triangle overlaps. Cells are enumerated in columns along the axis D where
 * the normal is largest: over a column the plane's crossing spans at most (|nU|+|nV|)/|nD| <= 2
 * cells, and each row of columns is cut to the projected triangle, so the work is proportional to
 * the number of cells marked, never to the bounding-box volume: a 512x512 ground plate costs about
 * 512^2 cell tests. Ranges derived in floating point are widened by a cell against rounding; the
 * exact SAT (tribox.h: plane + three projected edge tests) decides every cell. */
static void voxelize_triangle(build_job *job, const float c[9])
{
    double v[3][3];
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++)
            v[k][a] = ((double)c[3 * k + a] - job->origin[a]) / job->voxel_size;
    tribox_cells s;
    if (!tribox_cells_setup(&s, v[0], v[1], v[2]))
        return; /* zero area: no surface to voxelise */
    dense_bits *bits = job->bits;
    int n = bits->n;
    int lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = clampi(s.lo[a], 0, n - 1);
        hi[a] = clampi(s.hi[a], 0, n - 1);
        if (lo[a] > hi[a])
            return;
    }
    const int D = s.dominant, U = (D + 1) % 3, V = (D + 2) % 3;
    const double nU = s.n[U], nV = s.n[V], nD = s.n[D], inv_nD = 1.0 / nD;
    /* Row cut: edge i of the D projection passes cells with A*u + B*v + C >= 0, a bound on v
     * for each edge with B != 0. */
    const double(*E)[3] = s.edge[D];
    double inv_B[3];
    for (int i = 0; i < 3; i++)
        inv_B[i] = E[i][1] != 0.0 ? 1.0 / E[i][1] : 0.0;
    size_t cur_word = SIZE_MAX;
    uint64_t cur_mask = 0;
    for (int u = lo[U]; u <= hi[U]; u++) {
        double vlo = (double)lo[V], vhi = (double)hi[V];
        int skip = 0;
        for (int i = 0; i < 3; i++) {
            double r = E[i][0] * (double)u + E[i][2];
            if (E[i][1] > 0.0)
                vlo = dmax(vlo, -r * inv_B[i] - 1.0);
            else if (E[i][1] < 0.0)
                vhi = dmin(vhi, -r * inv_B[i] + 1.0);
            else if (r < 0.0)
                skip = 1;
        }
        if (skip || vlo > vhi + 1.0)
            continue;
        /* vlo, vhi are within [lo[V] - 1, hi[V] + 1] here, so the conversions are safe. */
        int v0 = clampi((int)floor(vlo), lo[V], hi[V]), v1 = clampi((int)ceil(vhi), lo[V], hi[V]);
        for (int vv = v0; vv <= v1; vv++) {
            if (!tribox_cells_edges(&s, D, (double)u, (double)vv))
                continue;
            /* Plane crossing of this column: plane_lo <= nU*u + nV*v + nD*w <= plane_hi. */
            double r = nU * (double)u + nV * (double)vv;
            double wa = (s.plane_lo - r) * inv_nD, wb = (s.plane_hi - r) * inv_nD;
            if (wa > wb) {
                double tmp = wa;
                wa = wb;
                wb = tmp;
            }
            wa = dmax(floor(wa), (double)lo[D]);
            wb = dmin(ceil(wb), (double)hi[D]);
            if (wa > wb)
                continue; /* also keeps the int conversions below in range */
            for (int w = (int)wa; w <= (int)wb; w++) {
                double np = r + nD * (double)w;
                if (np < s.plane_lo || np > s.plane_hi || !tribox_cells_edges(&s, U, (double)vv, (double)w) ||
                    !tribox_cells_edges(&s, V, (double)w, (double)u))
                    continue;
                int p[3];
                p[D] = w;
                p[U] = u;
                p[V] = vv;
                size_t word = dense_word(bits, p[0], p[1], p[2] >> 6);
                uint64_t bit = UINT64_C(1) << (p[2] & 63);
                /* Runs along z (D = 2) fall in one word: gather them into one OR. */
                if (word != cur_word) {
                    if (cur_mask)
                        set_bits(&bits->w[cur_word], cur_mask);
                    cur_word = word;
                    cur_mask = 0;
                }
                cur_mask |= bit;
            }
        }
    }
    if (cur_mask)
        set_bits(&bits->w[cur_word], cur_mask);
}

static void *build_worker(void *arg)
{
    build_job *job = arg;
    const grid_triangles *src = job->src;
    float corners[BUILD_CHUNK][9];
    for (;;) {
        size_t first = __atomic_fetch_add(&job->next, BUILD_CHUNK, __ATOMIC_RELAXED);
        if (first >= src->count)
            break;
        size_t n = first + BUILD_CHUNK < src->count ? BUILD_CHUNK : src->count - first;
        src->corners(src->ctx, first, n, corners);
        for (size_t i = 0; i < n; i++)
            voxelize_triangle(job, corners[i]);
    }
    return NULL;
}

static void mesh_corners(const void *ctx, size_t first, size_t n, float (*out)[9])
{
    const mesh *m = ctx;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            memcpy(&out[i][3 * k], m->positions + 3 * (size_t)m->indices[3 * (first + i) + (size_t)k], 3 * sizeof(float));
}

static int dense_alloc(dense_bits *d, int n)
{
    d->n = n;
    d->W = (n + 63) / 64;
    d->bt = (n + 3) / 4;
    d->bytes = (size_t)d->bt * (size_t)d->bt * (size_t)d->W * 16 * sizeof(uint64_t);
    d->w = big_alloc(d->bytes);
    return d->w ? 0 : -1;
}

static void dense_free(dense_bits *d)
{
    big_free(d->w, d->bytes);
    d->w = NULL;
}

/* Dense bits of the next coarser level: OR of the 4 child columns, then pairs of z bits. Word j of
 * a coarse column covers child words 2j and 2j+1 (2j is always inside the child column). Walks
 * the coarse bricks: the children of one are 2x2 fine bricks, read as 128-byte runs. Children past
 * n are brick padding (zero), so the coarse padding stays zero too. */
static void downsample(const dense_bits *src, dense_bits *dst)
{
    for (int BX = 0; BX < dst->bt; BX++)
        for (int BY = 0; BY < dst->bt; BY++)
            for (int j = 0; j < dst->W; j++) {
                uint64_t a[16] = {0}, b[16] = {0};
                for (int s = 0; s < 4; s++) {
                    int sbx = 2 * BX + (s >> 1), sby = 2 * BY + (s & 1);
                    if (sbx >= src->bt || sby >= src->bt)
                        continue;
                    const uint64_t *wa = src->w + ((((size_t)sbx * (size_t)src->bt + (size_t)sby) * (size_t)src->W +
                                                    (size_t)(2 * j)) << 4);
                    int has_b = 2 * j + 1 < src->W;
                    for (int i = 0; i < 16; i++) {
                        /* Fine column (i/4, i%4) of brick s -> coarse column of this brick. */
                        int o = ((s >> 1) * 2 + (i >> 3)) * 4 + (s & 1) * 2 + ((i & 3) >> 1);
                        a[o] |= wa[i];
                        if (has_b)
                            b[o] |= wa[16 + i];
                    }
                }
                uint64_t *out = dst->w + ((((size_t)BX * (size_t)dst->bt + (size_t)BY) * (size_t)dst->W + (size_t)j) << 4);
                for (int o = 0; o < 16; o++)
                    out[o] = halve_words(a[o], b[o]);
            }
}

/* Sparse form of a dense level (see grid.h). A first pass over the dense bricks (contiguous) finds
 * each column's mask of non-zero words and the totals; the second pass visits the columns in index
 * order but reads only their non-zero words. */
static int compact_level(grid_level *L, const dense_bits *d, vx_err *e)
{
    int n = d->n, W = d->W;
    L->n = n;
    L->words_per_col = W;
    L->cols = big_alloc(cols_bytes(L));
    if (!L->cols)
        return vx_fail(e, "grid_build: out of memory for a %d^3 level", n);
    size_t words = 0, count = 0, bricks = (size_t)d->bt * (size_t)d->bt * (size_t)W;
    for (size_t brick = 0; brick < bricks; brick++) {
        const uint64_t *w = d->w + (brick << 4);
        int j = (int)(brick % (size_t)W);
        size_t bxy = brick / (size_t)W;
        int x0 = (int)(bxy / (size_t)d->bt) * 4, y0 = (int)(bxy % (size_t)d->bt) * 4;
        for (int i = 0; i < 16; i++) {
            if (!w[i])
                continue; /* brick padding past n is always zero, so x, y < n below */
            L->cols[(size_t)(x0 + (i >> 2)) * (size_t)n + (size_t)(y0 + (i & 3))] |= UINT64_C(1) << j;
            words++;
            count += (size_t)__builtin_popcountll(w[i]);
        }
    }
    L->words = words;
    L->count = count;
    L->bits = big_alloc(bits_bytes(L));
    L->prefix = big_alloc(prefix_bytes(L));
    L->coords = big_alloc(coords_bytes(L));
    if (!L->bits || !L->prefix || !L->coords)
        return vx_fail(e, "grid_build: out of memory for a %d^3 level (%zu voxels)", n, count);
    size_t wi = 0, c = 0;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++) {
            uint64_t *col = &L->cols[(size_t)x * (size_t)n + (size_t)y];
            uint64_t first = wi, mask = *col;
            for (uint64_t m = mask; m; m &= m - 1) {
                int j = __builtin_ctzll(m);
                uint64_t w = d->w[dense_word(d, x, y, j)];
                L->bits[wi] = w;
                L->prefix[wi] = (uint32_t)c;
                wi++;
                uint32_t xyz = (uint32_t)x << 20 | (uint32_t)y << 10 | (uint32_t)(j * 64);
                for (; w; w &= w - 1)
                    L->coords[c++] = xyz + (uint32_t)__builtin_ctzll(w);
            }
            *col = first << 16 | mask;
        }
    return 0;
}

/* Bounds over the vertices of all triangles, validating indices and coordinates on the way. */
static int mesh_bounds(const mesh *m, double lo[3], double hi[3], vx_err *e)
{
    for (int a = 0; a < 3; a++) {
        lo[a] = INFINITY;
        hi[a] = -INFINITY;
    }
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t i = m->indices[3 * t + k];
            if (i >= m->vertex_count)
                return vx_fail(e, "grid_build: triangle %zu uses vertex %u but the mesh has %zu vertices", t,
                               i, m->vertex_count);
            const float *p = m->positions + 3 * (size_t)i;
            for (int a = 0; a < 3; a++) {
                if (!isfinite(p[a]))
                    return vx_fail(e, "grid_build: vertex %u (triangle %zu) has a non-finite coordinate %g", i,
                                   t, (double)p[a]);
                lo[a] = vx_fmin(lo[a], p[a]);
                hi[a] = vx_fmax(hi[a], p[a]);
            }
        }
    return 0;
}

/* The mapping documented in grid.h from bounds lo/hi, in double so that scenes far from the origin
 * (1e6) or smaller than a float ulp there keep exact cell boundaries. */
void grid_set_mapping(voxel_grid *g, int n, const double lo[3], const double hi[3])
{
    double extent = vx_fmax(hi[0] - lo[0], vx_fmax(hi[1] - lo[1], hi[2] - lo[2]));
    if (!(extent > 0.0)) {
        /* Every vertex at one point: only zero-area triangles, nothing to mark, but the mapping
         * must still be valid. */
        double mag = vx_fmax(vx_fmax(fabs(lo[0]), fabs(lo[1])), fabs(lo[2]));
        extent = mag > 0.0 ? mag * 1e-6 : 1e-6;
    }
    double pad = vx_fmin(1.5, n / 4.0);
    g->n = n;
    g->voxel_size_d = extent / (n - 2.0 * pad);
    for (int a = 0; a < 3; a++)
        g->origin_d[a] = lo[a] - pad * g->voxel_size_d;
    g->origin = v3((float)g->origin_d[0], (float)g->origin_d[1], (float)g->origin_d[2]);
    g->voxel_size = (float)g->voxel_size_d;
    g->levels = 1;
    for (int s = n; s > 1; s = (s + 1) / 2)
        g->levels++;
}

/* Level by level: compact the dense bits, derive the next level's, drop the finer ones. Takes
 * ownership of `dense`; on failure g is freed. */
static int build_levels(voxel_grid *g, dense_bits dense, vx_err *e)
{
    for (int l = 0; l < g->levels; l++) {
        if (compact_level(&g->level[l], &dense, e) || level_fill_dense(&g->level[l], l, e)) {
            dense_free(&dense);
            grid_free(g);
            return -1;
        }
        if (l + 1 == g->levels)
            break;
        dense_bits coarse;
        if (dense_alloc(&coarse, (dense.n + 1) / 2)) {
            dense_free(&dense);
            grid_free(g);
            return vx_fail(e, "grid_build: out of memory for MIP level %d", l + 1);
        }
        downsample(&dense, &coarse);
        dense_free(&dense);
        dense = coarse;
    }
    dense_free(&dense);
    return 0;
}

int grid_build_triangles(voxel_grid *g, const grid_triangles *src, int n, const double lo[3], const double hi[3],
                         int threads, vx_err *e)
{
    memset(g, 0, sizeof *g);
    if (n < 1 || n > GRID_MAX_N)
        return vx_fail(e, "grid_build: resolution %d is outside 1..%d", n, GRID_MAX_N);
    if (src->count == 0)
        return vx_fail(e, "grid_build: the mesh has no triangles");
    grid_set_mapping(g, n, lo, hi);
    dense_bits dense;
    if (dense_alloc(&dense, n)) {
        memset(g, 0, sizeof *g);
        return vx_fail(e, "grid_build: out of memory for the %d^3 occupancy bits", n);
    }
    build_job job = {.src = src, .voxel_size = g->voxel_size_d, .bits = &dense};
    memcpy(job.origin, g->origin_d, sizeof job.origin);
    if (threads < 1)
        threads = 1;
    if (threads > 64)
        threads = 64;
    pthread_t tid[64];
    int started = 0;
    for (int i = 1; i < threads; i++) {
        if (pthread_create(&tid[started], NULL, build_worker, &job) != 0)
            break; /* fewer threads only costs time: the calling thread finishes the work */
        started++;
    }
    build_worker(&job);
    for (int i = 0; i < started; i++)
        pthread_join(tid[i], NULL);
    return build_levels(g, dense, e);
}

int grid_take_lattice(double lo[3], double hi[3], const double *blo, const double *bhi, vx_err *e)
{
    if (blo) /* the caller's lattice (an animation's): the triangles must lie inside it */
        for (int a = 0; a < 3; a++) {
            if (lo[a] < blo[a] || hi[a] > bhi[a])
                return vx_fail(e, "grid_build: the mesh leaves the given bounds on axis %d", a);
            lo[a] = blo[a], hi[a] = bhi[a];
        }
    return 0;
}

static int grid_build_impl(voxel_grid *g, const mesh *m, int n, const double *blo, const double *bhi, int threads,
                           vx_err *e)
{
    memset(g, 0, sizeof *g);
    if (n < 1 || n > GRID_MAX_N)
        return vx_fail(e, "grid_build: resolution %d is outside 1..%d", n, GRID_MAX_N);
    if (!m || m->triangle_count == 0)
        return vx_fail(e, "grid_build: the mesh has no triangles");
    double lo[3], hi[3];
    if (mesh_bounds(m, lo, hi, e))
        return -1;
    if (grid_take_lattice(lo, hi, blo, bhi, e))
        return -1;
    grid_triangles src = {m->triangle_count, mesh_corners, m};
    return grid_build_triangles(g, &src, n, lo, hi, threads, e);
}

int grid_build_threads(voxel_grid *g, const mesh *m, int n, int threads, vx_err *e)
{
    return grid_build_impl(g, m, n, NULL, NULL, threads, e);
}

int grid_build_bounds(voxel_grid *g, const mesh *m, int n, const double lo[3], const double hi[3], vx_err *e)
{
    return grid_build_impl(g, m, n, lo, hi, 2, e);
}

int grid_build_dense_cells(voxel_grid *g, const uint32_t *cells, size_t count, vx_err *e)
{
    dense_bits dense;
    if (dense_alloc(&dense, g->n)) {
        memset(g, 0, sizeof *g);
        return vx_fail(e, "grid_build: out of memory for the %d^3 occupancy bits", g->n);
    }
    for (size_t i = 0; i < count; i++) {
        int x = (int)(cells[i] >> 20), y = (int)((cells[i] >> 10) & 1023u), z = (int)(cells[i] & 1023u);
        dense.w[dense_word(&dense, x, y, z >> 6)] |= UINT64_C(1) << (z & 63);
    }
    return build_levels(g, dense, e);
}

int grid_build(voxel_grid *g, const mesh *m, int n, vx_err *e) { return grid_build_threads(g, m, n, 2, e); }

void grid_free(voxel_grid *g)
{
    for (int l = 0; l < GRID_MAX_LEVELS; l++) {
        grid_level *L = &g->level[l];
        big_free(L->cols, cols_bytes(L));
        big_free(L->bits, bits_bytes(L));
        big_free(L->prefix, prefix_bytes(L));
        big_free(L->coords, coords_bytes(L));
        big_free(L->dense, dense_bytes(L, l));
    }
    memset(g, 0, sizeof *g);
}

size_t grid_bytes(const voxel_grid *g)
{
    size_t bytes = sizeof *g;
    for (int l = 0; l < g->levels; l++) {
        const grid_level *L = &g->level[l];
        bytes += cols_bytes(L) + bits_bytes(L) + prefix_bytes(L) + coords_bytes(L) + (L->dense ? dense_bytes(L, l) : 0);
    }
    return bytes;
}

vec3 grid_cell_center(const voxel_grid *g, int level, int x, int y, int z)
{
    double s = ldexp(g->voxel_size_d, level);
    const double *o = g->origin_d;
    return v3((float)(o[0] + (x + 0.5) * s), (float)(o[1] + (y + 0.5) * s), (float)(o[2] + (z + 0.5) * s));
}
