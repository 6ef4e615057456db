#include "grid_traverse.h"

#include <math.h>
#include <string.h>

/* Where the ray crosses plane `k` of axis a. Every boundary distance the iterator uses comes from
 * this one formula (never from accumulating t_delta), so the stepping, the clipping to the grid and
 * the jumps over empty ancestors agree exactly about the order of planes. */
static inline double plane_t(const grid_iter *it, int a, int k) { return ((double)k - it->o[a]) * it->inv[a]; }

static inline double exit_t(const grid_iter *it, int a, int c)
{
    if (it->dir[a] > 0)
        return plane_t(it, a, c + 1);
    if (it->dir[a] < 0)
        return plane_t(it, a, c);
    return INFINITY;
}

/* The cell of axis a, within [lo, hi], that the ray occupies just after t. The floor of the
 * position is only a guess: it is corrected against plane_t so that the answer is consistent with
 * the distances the stepping uses, whatever rounding did to o + t*d. */
static int cell_at(const grid_iter *it, int a, double t, int lo, int hi)
{
    int s = it->dir[a];
    double p = it->o[a] + t * it->d[a];
    double guess = s < 0 ? ceil(p) - 1.0 : floor(p);
    int c = guess < lo ? lo : (guess > hi ? hi : (int)guess); /* NaN-free: t and o are finite here */
    if (s > 0) {
        while (c < hi && plane_t(it, a, c + 1) <= t)
            c++;
        while (c > lo && plane_t(it, a, c) > t)
            c--;
    } else if (s < 0) {
        while (c > lo && plane_t(it, a, c) <= t)
            c--;
        while (c < hi && plane_t(it, a, c + 1) > t)
            c++;
    }
    return c;
}

int grid_iter_init(grid_iter *it, const voxel_grid *g, int level, vec3 origin, vec3 dir, float t_min,
                   float t_max)
{
    memset(it, 0, sizeof *it);
    it->g = g;
    it->level = level;
    if (!g || level < 0 || level >= g->levels)
        return 0;
    int n = g->level[level].n;
    it->n = n;
    /* Lattice units of this level: same t as in world space because origin and direction are
     * mapped by the same affine scale. */
    double scale = ldexp(g->voxel_size_d, level);
    double o[3] = {((double)origin.x - g->origin_d[0]) / scale, ((double)origin.y - g->origin_d[1]) / scale,
                   ((double)origin.z - g->origin_d[2]) / scale};
    double d[3] = {dir.x / scale, dir.y / scale, dir.z / scale};
    double t0 = t_min, t1 = t_max;
    if (!(t0 <= t1))
        return 0; /* also NaN */
    int moving = 0;
    for (int a = 0; a < 3; a++) {
        if (!isfinite(o[a]) || !isfinite(d[a]))
            return 0;
        it->o[a] = o[a];
        it->d[a] = d[a];
        if (d[a] == 0.0) {
            /* Parallel to this axis' planes: inside the half-open slab [0, n) or missing. */
            if (!(o[a] >= 0.0 && o[a] < n))
                return 0;
            it->dir[a] = 0;
            it->inv[a] = 0.0;
            continue;
        }
        moving = 1;
        it->dir[a] = d[a] > 0.0 ? 1 : -1;
        it->inv[a] = 1.0 / d[a];
        double ta = plane_t(it, a, 0), tb = plane_t(it, a, n);
        if (ta > tb) {
            double tmp = ta;
            ta = tb;
            tb = tmp;
        }
        t0 = fmax(t0, ta);
        t1 = fmin(t1, tb);
    }
    if (!moving || !(t0 < t1))
        return 0;
    it->t = t0;
    it->t_end = t1;
    for (int a = 0; a < 3; a++) {
        it->c[a] = it->dir[a] ? cell_at(it, a, t0, 0, n - 1) : (int)floor(o[a]);
        it->t_next[a] = exit_t(it, a, it->c[a]);
    }
    it->active = 1;
    return 1;
}

/* Into the neighbouring cell across the nearest exit plane (ties: lowest axis first), the ray
 * being at t1 there. */
static inline void step(grid_iter *it, double t1)
{
    if (t1 >= it->t_end) {
        it->active = 0;
        return;
    }
    int a = it->t_next[0] <= it->t_next[1] ? (it->t_next[0] <= it->t_next[2] ? 0 : 2)
                                           : (it->t_next[1] <= it->t_next[2] ? 1 : 2);
    int c = it->c[a] + it->dir[a];
    if (c < 0 || c >= it->n) {
        it->active = 0;
        return;
    }
    it->c[a] = c;
    it->t = t1;
    it->t_next[a] = exit_t(it, a, c);
}

/* Leaves the empty block of 2^k cells a side (the current cell's ancestor k levels up, clipped to
 * the grid) in one move: the exit plane is found as for a cell, and the other axes' cells at that
 * distance are found by cell_at inside the block's range. No axis moves backwards, so every jump
 * makes progress even when rounding disagrees about the exact crossing. */
static void jump(grid_iter *it, int k)
{
    int lo[3], hi[3], best = -1;
    double tb = INFINITY;
    for (int a = 0; a < 3; a++) {
        lo[a] = (it->c[a] >> k) << k;
        hi[a] = lo[a] + (1 << k) < it->n ? lo[a] + (1 << k) : it->n; /* exclusive */
        if (it->dir[a] == 0)
            continue;
        double ta = plane_t(it, a, it->dir[a] > 0 ? hi[a] : lo[a]);
        if (ta < tb) {
            tb = ta;
            best = a;
        }
    }
    tb = fmax(tb, it->t);
    if (best < 0 || tb >= it->t_end) {
        it->active = 0;
        return;
    }
    int nc = it->dir[best] > 0 ? hi[best] : lo[best] - 1;
    if (nc < 0 || nc >= it->n) {
        it->active = 0;
        return;
    }
    for (int a = 0; a < 3; a++) {
        if (a == best || it->dir[a] == 0)
            continue;
        int c = cell_at(it, a, tb, lo[a], hi[a] - 1);
        it->c[a] = it->dir[a] > 0 ? (c > it->c[a] ? c : it->c[a]) : (c < it->c[a] ? c : it->c[a]);
    }
    it->c[best] = nc;
    it->t = tb;
    for (int a = 0; a < 3; a++)
        it->t_next[a] = exit_t(it, a, it->c[a]);
}

int grid_iter_next(grid_iter *it, grid_hit *hit)
{
    const voxel_grid *g = it->g;
    while (it->active) {
        const grid_level *L = &g->level[it->level];
        int64_t idx = grid_level_index(L, it->c[0], it->c[1], it->c[2]);
        if (idx >= 0) {
            double t1 = fmin(fmin(it->t_next[0], it->t_next[1]), fmin(it->t_next[2], it->t_end));
            t1 = fmax(t1, it->t);
            hit->x = it->c[0];
            hit->y = it->c[1];
            hit->z = it->c[2];
            hit->index = idx;
            hit->t0 = (float)it->t;
            hit->t1 = (float)t1;
            step(it, t1);
            return 1;
        }
        /* Empty: find the largest empty ancestor and leave it. */
        int k = 0;
        while (it->level + k + 1 < g->levels &&
               grid_level_index(&g->level[it->level + k + 1], it->c[0] >> (k + 1), it->c[1] >> (k + 1),
                                it->c[2] >> (k + 1)) < 0)
            k++;
        if (k == 0) {
            double t1 = fmin(fmin(it->t_next[0], it->t_next[1]), fmin(it->t_next[2], it->t_end));
            step(it, fmax(t1, it->t));
        } else {
            jump(it, k);
        }
    }
    return 0;
}
