/* Cone marching for models with cone evaluation (vx_cone_eval; Heitz & Neyret 2012, §4-5), as portable C:
 * the C tracer (render_cone.c) and the OpenCL cone kernel (cl/render_cone.cl) both run this code.
 *
 * One cone per pixel, split into cone elements whose length equals their diameter; each element's
 * MIP level follows its width; the model answers each element (coverage mask + radiance) and the
 * answers are composited A-buffer style:
 *     L += L_d popcount(M_d & ~A) / 128,  A |= M_d,  stop when A is full.
 * Shadows (when declared) march a light cone from each contributing element with the same
 * elements; the light's transmittance is 1 - the covered fraction; with the light cache
 * (cone_light_cache.h) the cones are cast once per cell. Depth of field (when declared) widens the
 * cone with the thin lens instead of sampling the lens. Empty space is skipped with the grid's
 * occupancy (cone_skip.h's dilated bitmaps where a level has one).
 *
 * The includer defines CONE_ELEMENT(ctx, q, a): the model's cone element (a function pointer call
 * in C, the model's portable function by name in OpenCL C, which has no function pointers). It may
 * define CONE_LIGHT_END(ctx, c, t_end): a t at or before t_end past which light cone c has no
 * element that the model is asked about (the C backend's maps, render_cone.c; exact: the cone's
 * answer is the same bits; without it the light cones march to the grid's edge), and
 * CONE_CAMERA_END(ctx, t_end): a t at or before t_end past which the camera cone being traced has no
 * element that the model is asked about, or below its start when it has none (the C backend's
 * per-pixel map, render_cone.c; exact as the light cones' ends; without it camera cones march to
 * the grid's edge).
 * No recursion either: the shaded march calls the light cones' march, which shades nothing. */
#ifndef VX_RENDER_CONE_CORE_H
#define VX_RENDER_CONE_CORE_H

#include "cone_levels.h"
#include "cone_light_cache.h"
#include "cone_skip.h"
#include "floor_int.h"
#include "grid_core.h"
#include "light.h"
#include "model.h"
#include "portable_hints.h"
#include "shadow_maps_core.h"

#ifndef CONE_ELEMENT
#error "define CONE_ELEMENT(ctx, q, a) before including render_cone_core.h"
#endif

#ifndef CONE_LIGHT_END
#define CONE_LIGHT_END(x, c, t_end) (t_end)
#endif
#ifndef CONE_CAMERA_END
#define CONE_CAMERA_END(x, t_end) (t_end)
#endif

#define CONE_MAX_ELEMENTS (1 << 20) /* a runaway guard; real cones use a few hundred at most */
/* The narrowest light cone, in voxel sizes: the light cache's, an element of level 1/2 (elements of
 * level 0 are 1 to 2 voxels wide). slicemap-model's columns are no narrower (slicemap_model.c): a
 * column finer than a voxel asked the model for coverage at a scale below its voxels, where its
 * planes let light through, and the maps' error against the march grew with --shadow-res (the
 * fidelity audit: against heitz-neyret's own march, MSE 6.2e-4 at 48 columns, 1.3e-3 at 768). */
#define CONE_LIGHT_MIN_RADIUS 0.70710678f
#define CONE_FULL_MASK (32 * VX_MASK_WORDS)

/* What a cone march counts (render statistics). */
typedef struct {
    uint64_t elements, shadow_rays, evals, cache_hits;
} cone_counts;

/* Everything a march reads: the grid and its skipping bitmaps, the model's records and table, the
 * light cache, the scene's lights and effects; and the counters it adds to. */
typedef struct cone_ctx {
    const voxel_grid *g;
    const dilated_grid *skip;       /* NULL: ask the sparse grid */
    VX_GLOBAL const void *records;
    VX_GLOBAL const void *table;    /* the model's constant table (vx_model.table) or NULL */
    const cone_light_cache *lcache; /* NULL: every element casts its own light cones */
    light lights[VX_MAX_LIGHTS];
    int light_count;
    unsigned effects;               /* VX_EFFECT_* */
    shadow_maps shadows;            /* precomputed shadows (shadow_maps_core.h); p NULL: light cones */
    cone_counts counts;
#ifndef __OPENCL_VERSION__
    const struct vx_model *m;       /* for CONE_ELEMENT in C */
    const struct cone_light_clips *clips; /* for CONE_LIGHT_END in C (render_cone.c); NULL: none */
    float camera_end; /* for CONE_CAMERA_END in C: the traced camera cone's (render_cone.c) */
    uint64_t model_cycles;
    int timed; /* the element calls are timed in this row (render_internal.h) */
#endif
} cone_ctx;

/* A cone: axis org + t dir (unit dir), radius(t) = sqrt((r0 + spread t)^2 + lens(t)^2), lens(t) the
 * thin lens's circle of confusion, aperture |z - focus| / focus at depth z = t fwd_cos. The two
 * blurs add in quadrature: the disk equivalent (same second moment) of two disks convolved. */
typedef struct {
    vec3 org, dir;
    float r0, spread;
    float aperture, focus, fwd_cos;
    float r_min; /* a floor: a zero-width cone would step zero lengths */
} cone;

VX_INLINE float cone_radius(const cone *c, float t)
{
    float r = c->r0 + c->spread * t;
    if (c->aperture > 0.0f) {
        float lens = c->aperture * fabsf(t * c->fwd_cos - c->focus) / c->focus;
        r = sqrtf(r * r + lens * lens);
    }
    return r > c->r_min ? r : c->r_min;
}

/* The ray's interval inside the grid's box grown by `margin` on every side; 0 when it misses. */
VX_INLINE int cone_clip_to_grid(const voxel_grid *g, vec3 org, vec3 dir, float margin, float *t0, float *t1)
{
    float a = 0.0f, b = INFINITY;
    for (int k = 0; k < 3; k++) {
        float o = v3_get(org, k), d = v3_get(dir, k);
        float lo = (float)g->origin_d[k] - margin, hi = (float)(g->origin_d[k] + g->n * g->voxel_size_d) + margin;
        if (fabsf(d) < 1e-30f) {
            if (o < lo || o > hi)
                return 0;
            continue;
        }
        float u = (lo - o) / d, v = (hi - o) / d;
        if (u > v) {
            float s = u;
            u = v;
            v = s;
        }
        a = vx_fmaxf(a, u);
        b = vx_fminf(b, v);
    }
    *t0 = a;
    *t1 = b;
    return a < b;
}

/* The part of cone c (axis org + t dir, unit dir, t >= 0) that can meet the grid: its axis clipped
 * to the grid's box grown by how far an element's lookups reach, 4 radii (an element of radius r
 * reads the 2x2x2 cells around its centre on the levels whose cells are at most 2 r and 4 r wide,
 * so a cell more than 4 r away is never read). r is the cone's largest radius over the axis up to
 * the grown box's farthest corner (the radius is convex in t, so that is one of the two ends).
 * Why not the axis alone: the grid has a cell and a half of level 0 around the scene, and a cone
 * reads cells up to a few cells of its level from its axis. A ground plate on the box's bottom
 * face, seen at a slant, was covered only by the elements whose axis point was still inside the
 * box, so the background showed through where the coarse cones read it, more so as the voxels
 * shrank (issue 15's audit: a flat plate at 16x16 pixels, MSE 1.6e-4 at 64^3 and 5.1e-3 at
 * 256^3); and a pixel whose axis passed just beside the box saw nothing of the cells its cone
 * covered. */
VX_INLINE int cone_clip_reach(const voxel_grid *g, const cone *c, float *t0, float *t1)
{
    float span = (float)(g->n * g->voxel_size_d), far2 = 0.0f;
    for (int k = 0; k < 3; k++) {
        float lo = (float)g->origin_d[k] - v3_get(c->org, k);
        float d = vx_fmaxf(fabsf(lo), fabsf(lo + span));
        far2 += d * d;
    }
    float far = sqrtf(far2), r0 = cone_radius(c, 0.0f);
    float margin = 4.0f * vx_fmaxf(r0, cone_radius(c, far));
    /* the grown box's farthest corner lies at most sqrt(3) margins farther */
    margin = 4.0f * vx_fmaxf(r0, cone_radius(c, far + 1.75f * margin));
    return cone_clip_to_grid(g, c->org, c->dir, margin, t0, t1);
}

/* Whether any cell of column (x, y) of L with z in [z0, z1] is non-empty (the range clipped to
 * the level): the column's occupancy is stored as 64-cell words along z (grid.h), so a run of z
 * costs one or two word tests instead of one lookup per cell. */
VX_INLINE int cone_column_any(const grid_level *L, int x, int y, int z0, int z1)
{
    if (z0 < 0)
        z0 = 0;
    if (z1 > L->n - 1)
        z1 = L->n - 1;
    if (z0 > z1)
        return 0;
    uint64_t col = L->cols[(size_t)x * (size_t)L->n + (size_t)y];
    uint32_t mask = (uint32_t)(col & 0xffffu);
    if (!mask)
        return 0;
    for (int j = z0 >> 6; j <= z1 >> 6; j++) {
        if (!((mask >> j) & 1u))
            continue;
        uint64_t bits = L->bits[(size_t)(col >> 16) + (size_t)VX_POPCOUNT32(mask & ((1u << j) - 1u))];
        int lo = j == z0 >> 6 ? z0 & 63 : 0, hi = j == z1 >> 6 ? z1 & 63 : 63;
        uint64_t m = bits >> lo;
        if (hi - lo < 63)
            m &= (((uint64_t)1) << (hi - lo + 1)) - 1u;
        if (m)
            return 1;
    }
    return 0;
}


/* cone_neighbourhood_empty for a level without a dilated bitmap: the sparse grid's columns, the
 * centre column first (near surfaces it answers). */
VX_INLINE int cone_neighbourhood_empty_sparse(const cone_ctx *x, int level, const int c[3])
{
    const grid_level *L = &x->g->level[level];
    unsigned n = (unsigned)L->n;
    if ((unsigned)c[0] < n && (unsigned)c[1] < n && cone_column_any(L, c[0], c[1], c[2] - 1, c[2] + 1))
        return 0;
    for (int dx = -1; dx <= 1; dx++) {
        int xx = c[0] + dx;
        if ((unsigned)xx >= n)
            continue;
        for (int dy = -1; dy <= 1; dy++) {
            int y = c[1] + dy;
            if ((unsigned)y >= n || (dx == 0 && dy == 0))
                continue;
            if (cone_column_any(L, xx, y, c[2] - 1, c[2] + 1))
                return 0;
        }
    }
    return 1;
}

/* Whether the 3x3x3 cells of `level` around cell c are all empty: then no element centred anywhere
 * in cell c, at this level or any finer one, has a non-empty interpolation stencil (a stencil
 * reaches less than one cell away). One bit of the dilated bitmap where the level has one (the
 * common case, inlined); else the sparse grid's columns. */
VX_HOT_INLINE int cone_neighbourhood_empty(const cone_ctx *x, int level, const int c[3])
{
    if (x->skip && dilated_has(x->skip, level))
        return !dilated_any(x->skip, level, c[0], c[1], c[2]);
    return cone_neighbourhood_empty_sparse(x, level, c);
}

/* Distance along the ray from the lattice point u (units of `level`) to the exit of its cell;
 * per_cell[a] is the distance along the ray per level-0 cell along axis a (cone_walk_start; 0 for
 * an axis the ray does not move along). A multiply where a division per axis was: the divisions'
 * latency was a visible share of the OpenCL marcher. */
VX_INLINE double cone_cell_exit(int level, const double u[3], const double per_cell[3])
{
    double cells = (double)(1u << level), best = INFINITY;
    VX_UNROLL
    for (int a = 0; a < 3; a++) {
        if (per_cell[a] == 0.0)
            continue;
        double c = (double)vx_floor_int(u[a]);
        double bound = per_cell[a] > 0.0 ? c + 1.0 : c;
        double t = (bound - u[a]) * cells * per_cell[a];
        best = t < best ? t : best; /* not fmin: a libm call on the hot path */
    }
    return best;
}

typedef struct {
    unsigned int covered[VX_MASK_WORDS];
    int count; /* bits set in covered */
    vec3 color;
} cone_composite;

/* Where a march is: the next element's start t, and the empty-space skipping's memory. */
typedef struct {
    float t, t_end;
    int known_K, known[3]; /* the last cell whose neighbourhood was non-empty */
    int K_skip;            /* the level the last jump used */
    double per_cell[3];    /* distance along dir per level-0 cell along each axis (cone_cell_exit) */
    float level_scale;     /* 2 / voxel_size: an element's width in level-0 cells per unit radius */
    double inv_voxel_size; /* 1 / voxel_size_d, for cone_to_lattice */
} cone_walk;

/* grid_to_lattice by the reciprocal of the voxel size (within an ulp of it): three double
 * divisions per element step were on the marcher's longest latency chain (position -> lattice ->
 * cell -> occupancy). The element's cell only picks where empty-space skipping looks; the voxel
 * traversal (grid_traverse) keeps grid_to_lattice's exact quotient. */
VX_INLINE void cone_to_lattice(const voxel_grid *g, double inv_voxel_size, vec3 p, double out[3])
{
    out[0] = ((double)p.x - g->origin_d[0]) * inv_voxel_size;
    out[1] = ((double)p.y - g->origin_d[1]) * inv_voxel_size;
    out[2] = ((double)p.z - g->origin_d[2]) * inv_voxel_size;
}

/* An element's lattice coordinates (level-0 cells) within CONE_NEAR_CELLS of the origin on every axis
 * (NaN is not). The marcher takes their floors as ints; a cone wider than the scene (a camera 1e11
 * away, an aperture of 1 focused at 1e-6) reaches that far outside the grid, where the floor
 * overflowed (UBSan: vx_floor_int). Every cell of the grid lies far inside (GRID_MAX_N cells a
 * side). */
#define CONE_NEAR_CELLS 1073741824.0 /* 2^30 */

VX_INLINE int cone_lattice_near(const double lat[3])
{
    return fabs(lat[0]) < CONE_NEAR_CELLS && fabs(lat[1]) < CONE_NEAR_CELLS && fabs(lat[2]) < CONE_NEAR_CELLS;
}

/* The distance along the ray from lattice point lat to where every axis is back within half of
 * CONE_NEAR_CELLS (nothing lies between: no cell is that far out); INFINITY when an axis outside moves
 * away or not at all (per_cell as in cone_cell_exit). */
VX_INLINE double cone_lattice_return(const double lat[3], const double per_cell[3])
{
    double within = 0.5 * CONE_NEAR_CELLS, back = 0.0; /* not "half": an OpenCL type */
    for (int a = 0; a < 3; a++) {
        if (fabs(lat[a]) < within)
            continue;
        double target = lat[a] > 0.0 ? within : -within, d = (target - lat[a]) * per_cell[a];
        if (!(d > 0.0)) /* per_cell 0, or pointing away (NaN too) */
            return INFINITY;
        back = d > back ? d : back;
    }
    return back;
}

VX_INLINE void cone_walk_start(cone_walk *w, const voxel_grid *g, vec3 dir, float t, float t_end)
{
    for (int a = 0; a < 3; a++) {
        double d = v3_get(dir, a) / g->voxel_size_d; /* lattice cells per unit distance */
        w->per_cell[a] = fabs(d) < 1e-30 ? 0.0 : 1.0 / d;
    }
    w->level_scale = 2.0f / g->voxel_size;
    w->inv_voxel_size = 1.0 / g->voxel_size_d;
    w->t = t;
    w->t_end = t_end;
    w->known_K = -1;
    w->known[0] = w->known[1] = w->known[2] = 0;
    w->K_skip = 0;
}

/* Steps to the next element whose stencil may be non-empty: its centre p, radius r and fractional
 * level; 0 when the march leaves [t, t_end] (or the element guard runs out). The caller sets
 * w->t = centre + r after evaluating it. */
VX_HOT_INLINE int cone_next_element(const cone_ctx *x, const cone *c, cone_walk *w, int *steps, vec3 *p_out,
                                float *r_out, float *tc_out, float *level_out)
{
    const voxel_grid *g = x->g;
    float vs = g->voxel_size;
    int top = g->levels - 1;
    for (; *steps < CONE_MAX_ELEMENTS && w->t < w->t_end; (*steps)++) {
        float t = w->t;
        float r = cone_radius(c, t + cone_radius(c, t));
        float tc_ = t + r;
        vec3 p = v3_madd(c->org, c->dir, tc_);
        float level = cone_element_level(r, w->level_scale, top);
        /* Empty-space skipping over the coarse levels with hysteresis (as grid_traverse's DDA):
         * start at the level the last jump used, descend while the neighbourhood is occupied,
         * climb while the coarser one is empty, jump out of the cell. The element is asked about
         * exactly when its cell's neighbourhood on K_min is non-empty (a coarser level's empty
         * neighbourhood holds the finer one's). */
        int K_min = cone_proof_level(level, top);
        int K = w->K_skip > K_min ? w->K_skip : K_min;
        double lat[3], u[3];
        cone_to_lattice(g, w->inv_voxel_size, p, lat);
        if (!cone_lattice_near(lat)) {
            /* Far from every cell, where the cells' ints would overflow: on to where it comes back. */
            double back = cone_lattice_return(lat, w->per_cell);
            float t_back = tc_ + (float)back;
            if (!(back < INFINITY) || !(t_back > w->t)) /* or a step lost to t's rounding */
                return 0;
            w->t = t_back;
            continue;
        }
        int cell[3], empty = 0;
        for (;;) {
            double scale = vx_inv_pow2(K);
            VX_UNROLL
            for (int a = 0; a < 3; a++) {
                u[a] = lat[a] * scale;
                cell[a] = vx_floor_int(u[a]); /* u lies in the grid's box, cells 0..n */
            }
            /* Consecutive elements mostly share a cell: a neighbourhood found occupied stays so. */
            if (K == w->known_K && cell[0] == w->known[0] && cell[1] == w->known[1] && cell[2] == w->known[2])
                break;
            if (cone_neighbourhood_empty(x, K, cell)) {
                empty = 1;
                break;
            }
            if (K == K_min) {
                w->known_K = K;
                VX_UNROLL
                for (int a = 0; a < 3; a++)
                    w->known[a] = cell[a];
                break;
            }
            K--;
        }
        if (empty) {
            while (K < top) {
                int up[3] = {cell[0] >> 1, cell[1] >> 1, cell[2] >> 1};
                if (!cone_neighbourhood_empty(x, K + 1, up))
                    break;
                K++;
                VX_UNROLL
                for (int a = 0; a < 3; a++) {
                    cell[a] = up[a];
                    u[a] *= 0.5;
                }
            }
            w->K_skip = K;
            double exit = cone_cell_exit(K, u, w->per_cell);
            if (!(exit < INFINITY))
                return 0;
            w->t = tc_ + (float)exit + 1e-4f * vs * (float)(1u << K);
            continue;
        }
        w->K_skip = K_min;
        (*steps)++;
        *p_out = p;
        *r_out = r;
        *tc_out = tc_;
        *level_out = level;
        return 1;
    }
    return 0;
}

/* The query of an element (centre p, radius r, centre at tc_ along the cone) without lights. */
VX_INLINE void cone_element_query(const cone_ctx *x, const cone *c, vec3 p, float r, float tc_, float level,
                                  vx_query *q)
{
    vx_query zero = {0};
    *q = zero;
    q->ray_origin = c->org;
    q->ray_dir = c->dir;
    q->to_viewer = v3_scale(c->dir, -1.0f);
    q->effects = x->effects;
    q->grid = x->g;
    q->records = x->records;
    q->table = x->table;
    q->position = p;
    q->level = level;
    q->footprint = r;
    q->t0 = tc_ - r;
    q->t1 = tc_ + r;
    q->voxel_size = 2.0f * r;
    q->voxel_lo = v3_sub(p, v3(r, r, r));
}

/* Bits of m not yet in comp. */
VX_INLINE int cone_fresh(const cone_composite *comp, const unsigned int *m)
{
    int fresh = 0;
    for (int w = 0; w < VX_MASK_WORDS; w++)
        fresh += VX_POPCOUNT32(m[w] & ~comp->covered[w]);
    return fresh;
}

VX_INLINE void cone_cover(cone_composite *comp, const unsigned int *m)
{
    comp->count = 0;
    for (int w = 0; w < VX_MASK_WORDS; w++) {
        comp->covered[w] |= m[w];
        comp->count += VX_POPCOUNT32(comp->covered[w]);
    }
}

/* Light cone from point p of an element of radius r: a cylinder of the element's width (the lights
 * are points or directions), starting `start` past p (3 r: its first element centred 3 r away, as
 * the voxel tracer skips 1.5 voxel sizes) so that the surface it leaves does not shadow itself.
 * Only coverage accumulates. */
VX_INLINE float cone_light_transmittance(cone_ctx *x, vec3 p, float r, float start, vec3 to_light, float distance)
{
    x->counts.shadow_rays++;
    cone c = {p, to_light, r, 0.0f, 0.0f, 1.0f, 1.0f, 0.125f * x->g->voxel_size};
    float t0, t1;
    if (!cone_clip_reach(x->g, &c, &t0, &t1))
        return 1.0f;
    cone_composite comp = {{0, 0, 0, 0}, 0, {0.0f, 0.0f, 0.0f}};
    cone_walk w;
    cone_walk_start(&w, x->g, to_light, vx_fmaxf(t0, start), CONE_LIGHT_END(x, &c, vx_fminf(t1, distance)));
    int steps = 0;
    vec3 p_e;
    float r_e, tc_e, level_e;
    while (comp.count < CONE_FULL_MASK && cone_next_element(x, &c, &w, &steps, &p_e, &r_e, &tc_e, &level_e)) {
        x->counts.elements++;
        vx_query q;
        cone_element_query(x, &c, p_e, r_e, tc_e, level_e, &q);
        vx_answer a;
        CONE_ELEMENT(x, &q, &a);
        x->counts.evals++;
        if (cone_fresh(&comp, a.mask) > 0)
            cone_cover(&comp, a.mask);
        w.t = tc_e + r_e;
    }
    return 1.0f - (float)comp.count / (float)CONE_FULL_MASK;
}

/* Every light's transmittance for an element entering the scene's surface at p on MIP level
 * `level`, through the light cache: the canonical light cones of the cell of level floor(level)
 * that holds p, cast from the cell's centre with the radius of an element of level
 * floor(level) + 1/2 (elements of that level are 1 to 2 cells wide). The centre is within half a
 * cell's diagonal of p, inside the light cone's width, so its shadow is the element's own up to a
 * fraction of its blur (MSE and SSIM against the ground truth move either way by a few per cent;
 * without the cache every element casts its own cones). */
VX_INLINE void cone_cached_transmittance(cone_ctx *x, vec3 p, float level, int lights, float *T)
{
    const voxel_grid *g = x->g;
    int L = (int)level;
    double lat[3];
    grid_to_lattice(g, p, lat);
    int cell[3];
    for (int a = 0; a < 3; a++)
        cell[a] = (int)floor(lat[a] / (double)(1u << L));
    long slot = -1;
    if (cell[0] >= 0 && cell[1] >= 0 && cell[2] >= 0) { /* p lies in the grid's box */
        uint64_t key = cone_light_cache_key(L, cell[0] & 0xfffff, cell[1] & 0xfffff, cell[2] & 0xfffff);
        slot = cone_light_cache_slot(x->lcache, key);
        if (cone_light_cache_get(x->lcache, slot, T)) {
            x->counts.cache_hits++;
            return;
        }
    }
    /* The cell's centre (grid_cell_center's arithmetic). */
    double s = ldexp(g->voxel_size_d, L);
    vec3 centre = v3((float)(g->origin_d[0] + (cell[0] + 0.5) * s), (float)(g->origin_d[1] + (cell[1] + 0.5) * s),
                     (float)(g->origin_d[2] + (cell[2] + 0.5) * s));
    /* The element's radius at level L + 1/2, and its start (3 r, as for an element's own cone)
     * pushed out by half the cell's diagonal: the centre may lie that far below the surface that p
     * enters from outside, and a cone starting inside the surface would shadow itself. */
    float size = (float)s;
    float r = CONE_LIGHT_MIN_RADIUS * size, start = 3.0f * r + 0.8660254f * size;
    for (int li = 0; li < lights; li++) {
        vec3 to_light, irr;
        float dist;
        light_at(&x->lights[li], centre, &to_light, &irr, &dist);
        T[li] = cone_light_transmittance(x, centre, r, start, to_light, dist);
    }
    cone_light_cache_put(x->lcache, slot, T);
}

/* Marches camera cone c over [t, t_end], shading the elements that add coverage (lights with
 * their light cones when shadows are declared). */
VX_INLINE void cone_march_shaded(cone_ctx *x, const cone *c, float t, float t_end, cone_composite *comp)
{
    cone_walk w;
    cone_walk_start(&w, x->g, c->dir, t, t_end);
    int steps = 0;
    vec3 p;
    float r, tc_, level;
    while (comp->count < CONE_FULL_MASK && cone_next_element(x, c, &w, &steps, &p, &r, &tc_, &level)) {
        x->counts.elements++;
        vx_query q;
        cone_element_query(x, c, p, r, tc_, level, &q);
        /* Lights unshadowed at first: most elements show nothing, and shadow cones are cast only
         * from those that add coverage. */
        vec3 irr[VX_MAX_LIGHTS];
        float dist[VX_MAX_LIGHTS];
        q.light_count = x->light_count < VX_MAX_LIGHTS ? x->light_count : VX_MAX_LIGHTS;
        for (int li = 0; li < q.light_count; li++) {
            light_at(&x->lights[li], p, &q.to_light[li], &irr[li], &dist[li]);
            q.irradiance[li] = irr[li];
            q.light_distance[li] = dist[li];
        }
        vx_answer a;
        CONE_ELEMENT(x, &q, &a);
        x->counts.evals++;
        int fresh = cone_fresh(comp, a.mask);
        if (fresh > 0) {
            if ((x->effects & VX_EFFECT_SHADOWS) && q.light_count > 0) {
                float T[VX_MAX_LIGHTS];
                int all_lit = 1;
                /* From where the camera ray enters the element: the surface lies within the
                 * element (it adds coverage) but not before it (the previous one did not), so the
                 * entry is outside the surface and the light cone does not start inside it. */
                vec3 entry = v3_madd(c->org, c->dir, tc_ - r);
                if (shadow_maps_active(&x->shadows)) {
                    /* Skip 3 r, as the light cone's start; r at least slicemap-model's columns'
                     * (their elements stand up to that far off the surface they cover). */
                    float rs = x->shadows.p->method == SHADOW_SLICEMAP_MODEL
                                   ? vx_fmaxf(r, CONE_LIGHT_MIN_RADIUS * x->g->voxel_size)
                                   : r;
                    for (int li = 0; li < q.light_count; li++)
                        T[li] = shadow_maps_transmittance(&x->shadows, li, entry, 3.0f * rs);
                }
                else if (x->lcache)
                    cone_cached_transmittance(x, entry, level, q.light_count, T);
                else
                    for (int li = 0; li < q.light_count; li++)
                        T[li] = cone_light_transmittance(x, entry, r, 3.0f * r, q.to_light[li], dist[li]);
                for (int li = 0; li < q.light_count; li++)
                    all_lit &= T[li] == 1.0f;
                if (q.light_count == 1) {
                    /* Radiance is linear in the one light's irradiance. */
                    a.radiance = v3_scale(a.radiance, T[0]);
                } else if (!all_lit) {
                    for (int li = 0; li < q.light_count; li++)
                        q.irradiance[li] = v3_scale(irr[li], T[li]);
                    vx_answer b;
                    CONE_ELEMENT(x, &q, &b);
                    x->counts.evals++;
                    a.radiance = b.radiance;
                }
            }
            comp->color = v3_madd(comp->color, a.radiance, (float)fresh / (float)CONE_FULL_MASK);
            cone_cover(comp, a.mask);
        }
        w.t = tc_ + r;
    }
}

/* One pixel's cone: (org, dir) is the pixel's centre ray from the lens centre (dir unit); spread the
 * pixel's half-width per unit distance on the axis (camera_cone_spread); aperture, focus and forward
 * the thin lens (aperture 0: none). */
VX_INLINE vec3 cone_trace(cone_ctx *x, vec3 org, vec3 dir, float spread, float aperture, float focus, vec3 forward,
                          vec3 background)
{
    float fwd_cos = v3_dot(dir, forward);
    cone c = {org,
              dir,
              0.0f,
              camera_cone_spread(spread, fwd_cos),
              aperture,
              vx_fmaxf(focus, 1e-6f),
              fwd_cos,
              0.125f * x->g->voxel_size};
    cone_composite comp = {{0, 0, 0, 0}, 0, {0.0f, 0.0f, 0.0f}};
    float t0, t1;
    if (cone_clip_reach(x->g, &c, &t0, &t1))
        cone_march_shaded(x, &c, t0, CONE_CAMERA_END(x, t1), &comp);
    return v3_madd(comp.color, background, 1.0f - (float)comp.count / (float)CONE_FULL_MASK);
}

#endif
