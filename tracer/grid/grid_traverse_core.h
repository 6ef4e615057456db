/* Front-to-back traversal of the non-empty cells of one level of a voxel_grid along a ray: a 3D-DDA
 * (Amanatides & Woo 1987) that skips empty space using the coarser MIP levels. The DDA runs over
 * blocks of 2^k cells (the cells k levels up): an empty block is stepped over like a cell, k goes
 * up while the parent block is empty too, and a non-empty block makes k go down (into the child the
 * ray is in) until single cells are reached. A ray through an empty region thus costs about log2 of
 * its length in steps rather than one per cell; a step is a few multiply-adds and one or two
 * occupancy lookups.
 *
 * Iterator style: gt_iter_init, then gt_iter_next until it returns 0; stop whenever you like.
 * The iterator is a plain value, so copying it saves the position; to resume from a distance t
 * later, init again with t_min = t. For a shadow ray toward a point light pass t_max = the
 * distance to the light (same units as t, i.e. in multiples of |dir|).
 *
 * Conventions:
 *  - t is the parameter of origin + t * dir in world space (dir need not be unit length); the
 *    reported [t0, t1] is the ray's overlap with the cell clipped to [t_min, t_max], t0 <= t1, and
 *    successive cells have non-decreasing t0 (t1 of one cell = t0 of the next, whether or not the
 *    cells in between were empty).
 *  - A cell is [x, x+1) on an axis where the ray does not move: a ray lying exactly in a grid
 *    plane (a zero direction component with the origin on a cell boundary) belongs to the cells
 *    above the plane, and one on the grid's upper boundary plane misses the grid.
 *  - Where the ray is moving, the starting cell is the one it occupies just after t_min (an
 *    origin on a boundary going down starts below it). A ray crossing an edge or corner exactly
 *    may report a cell with t0 == t1 there.
 *  - A zero or non-finite direction, a NaN origin or an invalid level gives no cells.
 *
 * Portable C: no libc beyond <math.h>, no allocation. Both backends compile this same file (the C
 * marchers and the OpenCL kernels), so they visit exactly the same cells with the same [t0, t1]:
 * all the decisions are made in double by the same expressions (OpenCL C needs cl_khr_fp64 and
 * FP_CONTRACT OFF, which tracer/backends/opencl/cl/prelude.h sets, so that no multiply-add is fused
 * differently). gt_iter_init returns 1 when the ray overlaps the grid (with positive length), 0 when
 * it misses it; gt_iter_next fills the next non-empty cell and returns 1, or returns 0. */
#ifndef VX_GRID_TRAVERSE_CORE_H
#define VX_GRID_TRAVERSE_CORE_H

#include "grid_core.h"
#include "portable_hints.h"

/* How the iterator's two entry points and the walk's helpers are declared: a plain VX_INLINE here;
 * an includer may ask for more (tracer/backends/opencl/cl/render.cl forces inlining, so that the walk's state
 * stays in registers: PoCL otherwise calls gt_advance with the state in memory). */
#ifndef GT_ITER_INLINE
#define GT_ITER_INLINE VX_INLINE
#endif


typedef struct {
    int x, y, z;    /* cell coordinates at the iterator's level */
    int64_t index;  /* dense index at that level (see grid_index) */
    float t0, t1;   /* where the ray enters and leaves the cell */
} grid_hit;

typedef struct {
    const voxel_grid *g;
    int level, n;       /* level traversed, its cells per side */
    int active;         /* 0 once the ray has left the grid or passed t_max */
    int c[3];           /* current block (cell when k = 0), in units of 2^k cells */
    int dir[3];         /* step per axis (-1, 0, +1) */
    int fixed[3];       /* the cell on axes where the ray does not move */
    double o[3], inv[3]; /* ray origin in the level's lattice units, 1 / direction (0 where d = 0) */
    double d[3];
    double t, t_end;    /* entry of the current block, end of the ray in the grid */
    double t_next[3];   /* where the ray crosses the current block's exit plane on each axis */
    int k;              /* the walk is over blocks of 2^k cells (cells of the level k above) */
    int parent_ok;      /* the current block's parent is known to be non-empty */
} grid_iter;

/* Where the ray crosses plane `k` of axis a. Every boundary distance the iterator uses comes from
 * this one formula (never from accumulating t_delta), so the stepping, the clipping to the grid and
 * the steps over empty blocks and the descents into children agree exactly about the order of planes. */
VX_INLINE double gt_plane_t(const grid_iter *it, int a, int k) { return ((double)k - it->o[a]) * it->inv[a]; }

/* Where the ray leaves block b (2^k cells a side) on axis a. Blocks of the last row may stick out
 * of the grid: their exit plane then lies past t_end, which ends the walk anyway. */
VX_INLINE double gt_exit_t(const grid_iter *it, int a, int b, int k)
{
    if (it->dir[a] > 0)
        return gt_plane_t(it, a, (b + 1) << k);
    if (it->dir[a] < 0)
        return gt_plane_t(it, a, b << k);
    return INFINITY;
}

/* The cell of axis a, within [lo, hi], that the ray occupies just after t, and (*t_exit) where the
 * ray leaves it on that axis, gt_exit_t(it, a, c, 0) (the iterator starts at level 0 cells). The
 * floor of the position is only a guess: it is corrected against gt_plane_t so that the answer is
 * consistent with the distances the stepping uses, whatever rounding did to o + t*d. The planes'
 * distances are monotonic in the plane's number (rounding is monotonic), so the corrections end on
 * the same cell from any guess: the guess is taken by truncation toward zero, which is floor for
 * the positions that matter (p >= lo >= 0; the others clamp to lo anyway), rather than by floor()
 * and ceil(), which PoCL's library computes in software. The corrections compare t with the planes
 * on both sides of the cell, one of which is its exit plane: that distance is kept, not computed
 * again (the same expression, so the same bits; three fewer planes per walk's set-up). An axis
 * where the ray does not move (s == 0) has no exit plane: INFINITY. */
VX_INLINE int gt_cell_at_exit(const grid_iter *it, int a, double t, int lo, int hi, double *t_exit)
{
    int s = it->dir[a];
    double p = it->o[a] + t * it->d[a];
    int c;
    if (!(p >= lo)) /* also NaN (cannot happen: t and o are finite here) */
        c = lo;
    else if (p >= hi + 1.0)
        c = hi;
    else {
        c = (int)p;             /* floor(p): 0 <= lo <= p < hi + 1 */
        if (s < 0 && c == p && c > lo)
            c--;                /* ceil(p) - 1: the cell below a boundary, going down */
    }
    if (s > 0) {
        double up = gt_plane_t(it, a, c + 1); /* the exit plane, kept in step with c */
        while (c < hi && up <= t) {
            c++;
            up = gt_plane_t(it, a, c + 1);
        }
        double at;
        while (c > lo && (at = gt_plane_t(it, a, c)) > t) {
            c--;
            up = at;
        }
        *t_exit = up;
    } else if (s < 0) {
        double at = gt_plane_t(it, a, c); /* the exit plane, kept in step with c */
        while (c > lo && at <= t) {
            c--;
            at = gt_plane_t(it, a, c);
        }
        double up;
        while (c < hi && (up = gt_plane_t(it, a, c + 1)) > t) {
            c++;
            at = up;
        }
        *t_exit = at;
    } else
        *t_exit = INFINITY;
    return c;
}

/* Lattice units of a level: the same t as in world space, because the origin and the direction
 * are mapped by the same affine scale. voxel_size_d * 2^level is exact, as ldexp would be, without
 * its library call. */
VX_INLINE double gt_level_scale(const voxel_grid *g, int level) { return g->voxel_size_d * (double)(1 << level); }

/* A world-space point in a level's lattice units, as the iterator maps a ray's origin. */
VX_INLINE void gt_lattice_point(const voxel_grid *g, int level, vec3 p, double out[3])
{
    double scale = gt_level_scale(g, level);
    out[0] = ((double)p.x - g->origin_d[0]) / scale;
    out[1] = ((double)p.y - g->origin_d[1]) / scale;
    out[2] = ((double)p.z - g->origin_d[2]) / scale;
}

/* A ray's direction in a level's lattice units, with what the iterator derives from it: many rays
 * of one direction (the shadow rays toward a directional light) prepare it once, not six divisions
 * a ray. ok 0: the level is invalid or the direction is not finite (such a ray has no cells). */
typedef struct {
    double d[3], inv[3]; /* the direction over the level's scale; 1 / d (0 where d = 0) */
    int dir[3];          /* step per axis (-1, 0, +1) */
    int ok;
} gt_direction;

VX_INLINE void gt_direction_prepare(const voxel_grid *g, int level, vec3 dir, gt_direction *pd)
{
    pd->ok = 0;
    if (!g || level < 0 || level >= g->levels)
        return;
    double scale = gt_level_scale(g, level);
    pd->d[0] = dir.x / scale;
    pd->d[1] = dir.y / scale;
    pd->d[2] = dir.z / scale;
    pd->ok = 1;
    VX_UNROLL for (int a = 0; a < 3; a++) {
        pd->ok &= isfinite(pd->d[a]) != 0;
        pd->dir[a] = pd->d[a] > 0.0 ? 1 : (pd->d[a] < 0.0 ? -1 : 0);
        pd->inv[a] = pd->d[a] != 0.0 ? 1.0 / pd->d[a] : 0.0;
    }
}

/* gt_iter_init with the origin already mapped by gt_lattice_point (many rays from one point, a
 * frame's primary rays from the camera, map it once, not three divisions a ray) and the direction
 * prepared by gt_direction_prepare for the same level. */
GT_ITER_INLINE int gt_iter_init_prepared(grid_iter *it, const voxel_grid *g, int level, const double o[3],
                                         const gt_direction *pd, float t_min, float t_max)
{
    /* Only the fields a walk reads before it writes them are set (not the whole struct zeroed:
     * this runs once per ray): gt_iter_next reads g, level, active, k and parent_ok first. */
    it->g = g;
    it->level = level;
    it->active = 0;
    it->k = 0;
    it->parent_ok = 0;
    if (!g || level < 0 || level >= g->levels || !pd->ok)
        return 0;
    int n = g->level[level].n;
    it->n = n;
    double t0 = t_min, t1 = t_max;
    if (!(t0 <= t1))
        return 0; /* also NaN */
    int moving = 0;
    VX_UNROLL for (int a = 0; a < 3; a++) {
        if (!isfinite(o[a]))
            return 0;
        it->o[a] = o[a];
        it->d[a] = pd->d[a];
        it->dir[a] = pd->dir[a];
        it->inv[a] = pd->inv[a];
        if (pd->dir[a] == 0) {
            /* Parallel to this axis' planes: inside the half-open slab [0, n) or missing. */
            if (!(o[a] >= 0.0 && o[a] < n))
                return 0;
            continue;
        }
        moving = 1;
        double ta = gt_plane_t(it, a, 0), tb = gt_plane_t(it, a, n);
        if (ta > tb) {
            double tmp = ta;
            ta = tb;
            tb = tmp;
        }
        t0 = t0 > ta ? t0 : ta;
        t1 = t1 < tb ? t1 : tb;
    }
    if (!moving || !(t0 < t1))
        return 0;
    it->t = t0;
    it->t_end = t1;
    VX_UNROLL for (int a = 0; a < 3; a++) {
        double t_exit = INFINITY; /* gt_exit_t(it, a, c, 0) */
        it->c[a] = it->dir[a] ? gt_cell_at_exit(it, a, t0, 0, n - 1, &t_exit) : (int)o[a]; /* floor: 0 <= o[a] < n */
        it->fixed[a] = it->c[a];
        it->t_next[a] = t_exit;
    }
    it->active = 1;
    return 1;
}

/* gt_iter_init with the origin already mapped by gt_lattice_point. */
GT_ITER_INLINE int gt_iter_init_lattice(grid_iter *it, const voxel_grid *g, int level, const double o[3], vec3 dir,
                                        float t_min, float t_max)
{
    gt_direction pd;
    gt_direction_prepare(g, level, dir, &pd);
    return gt_iter_init_prepared(it, g, level, o, &pd, t_min, t_max);
}

/* The iterator's set-up (see the top of this file). */
GT_ITER_INLINE int gt_iter_init(grid_iter *it, const voxel_grid *g, int level, vec3 origin, vec3 dir, float t_min,
                           float t_max)
{
    double o[3] = {0.0, 0.0, 0.0};
    if (g && level >= 0 && level < g->levels)
        gt_lattice_point(g, level, origin, o);
    return gt_iter_init_lattice(it, g, level, o, dir, t_min, t_max);
}

VX_INLINE double gt_min2(double a, double b) { return a < b ? a : b; }
VX_INLINE double gt_max2(double a, double b) { return a > b ? a : b; }

/* The part of the iterator that a walk changes at every step, held in locals by gt_iter_next and
 * written back when it returns: indexed only by constants (the loops over the axes unroll, and the
 * step picks its axis by branching, below), so that a compiler that inlines the walk into its
 * caller (the OpenCL kernel, where PoCL otherwise keeps the iterator in private memory and reloads
 * each field through store-to-load forwarding) can keep them in registers. */
typedef struct {
    int c[3];
    double t_next[3];
    double t;
    int k, parent_ok;
} gt_walk;

/* One DDA step at the current block size along axis A (a constant at each call): into the
 * neighbouring block across that axis' exit plane. Only that axis changes, as in Amanatides & Woo.
 * Returns 0 when the ray leaves the grid. The exit plane needs no branch on the direction's sign:
 * the nearest exit plane is finite and below t_end, so axis A is moving. */
GT_ITER_INLINE int gt_step_axis(const grid_iter *it, gt_walk *w, int A, double t1, int nk)
{
    int b = w->c[A] + it->dir[A];
    if (b < 0 || b >= nk)
        return 0;
    if ((b ^ w->c[A]) >> 1)
        w->parent_ok = 0; /* crossed into another parent */
    w->c[A] = b;
    w->t = t1;
    w->t_next[A] = gt_plane_t(it, A, (b + (it->dir[A] > 0)) << w->k);
    return 1;
}

/* One DDA step across the nearest exit plane (ties: lowest axis first), ending at t1; returns 0
 * when the ray has left the grid or reached t_end. */
GT_ITER_INLINE int gt_advance(const grid_iter *it, gt_walk *w, double t1, int nk)
{
    if (t1 >= it->t_end)
        return 0;
    if (w->t_next[0] <= w->t_next[1]) {
        if (w->t_next[0] <= w->t_next[2])
            return gt_step_axis(it, w, 0, t1, nk);
    } else if (w->t_next[1] <= w->t_next[2])
        return gt_step_axis(it, w, 1, t1, nk);
    return gt_step_axis(it, w, 2, t1, nk);
}

GT_ITER_INLINE double gt_cell_exit(const grid_iter *it, const gt_walk *w)
{
    return gt_max2(gt_min2(gt_min2(w->t_next[0], w->t_next[1]), gt_min2(w->t_next[2], it->t_end)), w->t);
}

GT_ITER_INLINE void gt_walk_store(grid_iter *it, const gt_walk *w, int active)
{
    VX_UNROLL for (int a = 0; a < 3; a++) {
        it->c[a] = w->c[a];
        it->t_next[a] = w->t_next[a];
    }
    it->t = w->t;
    it->k = w->k;
    it->parent_ok = w->parent_ok;
    it->active = active;
}

/* The next non-empty cell (see the top of this file). */
GT_ITER_INLINE int gt_iter_next(grid_iter *it, grid_hit *hit)
{
    if (!it->active)
        return 0;
    const voxel_grid *g = it->g;
    const grid_level *lv = g->level + it->level; /* lv[k]: blocks of 2^k cells */
    const int top = g->levels - 1 - it->level;   /* largest k: a single block */
    gt_walk w;
    VX_UNROLL for (int a = 0; a < 3; a++) {
        w.c[a] = it->c[a];
        w.t_next[a] = it->t_next[a];
    }
    w.t = it->t;
    w.k = it->k;
    w.parent_ok = it->parent_ok;
    for (;;) {
        int k = w.k;
        if (k == 0) {
            int64_t idx = grid_level_index(lv, w.c[0], w.c[1], w.c[2]);
            if (idx >= 0) {
                double t1 = gt_cell_exit(it, &w);
                hit->x = w.c[0];
                hit->y = w.c[1];
                hit->z = w.c[2];
                hit->index = idx;
                hit->t0 = (float)w.t;
                hit->t1 = (float)t1;
                /* A non-empty cell has a non-empty parent. */
                w.parent_ok = 1;
                gt_walk_store(it, &w, gt_advance(it, &w, t1, lv[0].n));
                return 1;
            }
        } else if (grid_level_occupied(lv + k, w.c[0], w.c[1], w.c[2])) {
            /* Something in this block: go down to the child the ray is in at t, found by comparing
             * t with the crossing of each axis' mid-plane (just after t, like gt_cell_at_exit). The
             * child's exit plane is that mid-plane when the ray has not crossed it yet, else the
             * block's own exit plane: the same plane numbers as gt_exit_t's, whose distances are
             * already at hand (t_next always holds gt_exit_t of the current block), so they are
             * reused rather than computed again. */
            int h = k - 1, nh = lv[h].n;
            VX_UNROLL for (int a = 0; a < 3; a++) {
                int child;
                double exit_t = w.t_next[a]; /* INFINITY where the ray does not move on axis a */
                if (it->dir[a] == 0)
                    child = (it->fixed[a] >> h) & 1;
                else {
                    double mid = gt_plane_t(it, a, (2 * w.c[a] + 1) << h);
                    int crossed = mid <= w.t;
                    child = it->dir[a] > 0 ? crossed : !crossed;
                    exit_t = crossed ? exit_t : mid;
                }
                int b = 2 * w.c[a] + child;
                if (b >= nh) { /* a partial last block has one child */
                    b = nh - 1;
                    exit_t = gt_exit_t(it, a, b, h);
                }
                w.c[a] = b;
                w.t_next[a] = exit_t;
            }
            w.k = h;
            w.parent_ok = 1;
            continue;
        }
        /* Empty block: grow it while its parent is empty too, then step over it. */
        if (!w.parent_ok && k < top) {
            while (k < top) {
                if (grid_level_occupied(lv + k + 1, w.c[0] >> 1, w.c[1] >> 1, w.c[2] >> 1)) {
                    w.parent_ok = 1;
                    break;
                }
                k++;
                VX_UNROLL for (int a = 0; a < 3; a++)
                    w.c[a] >>= 1;
            }
            if (k != w.k) {
                w.k = k;
                VX_UNROLL for (int a = 0; a < 3; a++)
                    w.t_next[a] = gt_exit_t(it, a, w.c[a], k);
            }
        }
        if (!gt_advance(it, &w, gt_cell_exit(it, &w), lv[k].n)) {
            gt_walk_store(it, &w, 0);
            return 0;
        }
    }
}

#endif
