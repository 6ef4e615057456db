/* Cone marching for models that declare VX_MARCH_CONE (Heitz & Neyret 2012, §4-5): one cone per
 * pixel, split into cone elements whose length equals their diameter; each element's MIP level
 * follows its width; the model answers each element (coverage mask + radiance) through
 * cone_element and the answers are composited A-buffer style:
 *     L += L_d popcount(M_d & ~A) / 128,  A |= M_d,  stop when A is full.
 * Shadows (when declared) march a light cone from each contributing element with the same
 * elements; the light's transmittance is 1 - the covered fraction. Depth of field (when declared)
 * widens the cone with the thin lens instead of sampling the lens. Empty space is skipped with the
 * grid's occupancy. Knows models only through models/model.h. */
#include <math.h>
#include <string.h>

#include "camera.h"
#include "render_internal.h"
#include "rt.h"

#define CONE_MAX_ELEMENTS (1 << 20) /* a runaway guard; real cones use a few hundred at most */
#define FULL_MASK (32 * VX_MASK_WORDS)

/* A cone: axis org + t dir (unit dir), radius(t) = sqrt((r0 + spread t)^2 + lens(t)^2), lens(t) the
 * thin lens's circle of confusion, aperture |z - focus| / focus at depth z = t fwd_cos. The two
 * blurs add in quadrature: the disk equivalent (same second moment) of two disks convolved. */
typedef struct {
    vec3 org, dir;
    float r0, spread;
    float aperture, focus, fwd_cos;
    float r_min; /* a floor: a zero-width cone would step zero lengths */
} cone;

static float cone_radius(const cone *c, float t)
{
    float r = c->r0 + c->spread * t;
    if (c->aperture > 0.0f) {
        float lens = c->aperture * fabsf(t * c->fwd_cos - c->focus) / c->focus;
        r = sqrtf(r * r + lens * lens);
    }
    return r > c->r_min ? r : c->r_min;
}

/* The ray's interval inside the grid's box; 0 when it misses. */
static int clip_to_grid(const voxel_grid *g, vec3 org, vec3 dir, float *t0, float *t1)
{
    float a = 0.0f, b = INFINITY;
    for (int k = 0; k < 3; k++) {
        float o = v3_get(org, k), d = v3_get(dir, k);
        float lo = (float)g->origin_d[k], hi = (float)(g->origin_d[k] + g->n * g->voxel_size_d);
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
        a = fmaxf(a, u);
        b = fminf(b, v);
    }
    *t0 = a;
    *t1 = b;
    return a < b;
}

/* Whether any cell of column (x, y) of L with z in [z0, z1] is non-empty (the range clipped to
 * the level): the column's occupancy is stored as 64-cell words along z (grid.h), so a run of z
 * costs one or two word tests instead of one lookup per cell. */
static int column_any(const grid_level *L, int x, int y, int z0, int z1)
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
        uint64_t bits = L->bits[(size_t)(col >> 16) + (size_t)__builtin_popcount(mask & ((1u << j) - 1u))];
        int lo = j == z0 >> 6 ? z0 & 63 : 0, hi = j == z1 >> 6 ? z1 & 63 : 63;
        uint64_t m = bits >> lo;
        if (hi - lo < 63)
            m &= (UINT64_C(1) << (hi - lo + 1)) - 1u;
        if (m)
            return 1;
    }
    return 0;
}

/* Whether the 3x3x3 cells of `level` around cell c are all empty: then no element centred anywhere
 * in cell c, at this level or any finer one, has a non-empty interpolation stencil (a stencil
 * reaches less than one cell away). The centre column goes first: near surfaces it answers. */
static int neighbourhood_empty(const render_job *j, int level, const int c[3])
{
    if (j->skip && dilated_has(j->skip, level))
        return !dilated_any(j->skip, level, c[0], c[1], c[2]);
    const voxel_grid *g = j->g;
    const grid_level *L = &g->level[level];
    unsigned n = (unsigned)L->n;
    if ((unsigned)c[0] < n && (unsigned)c[1] < n && column_any(L, c[0], c[1], c[2] - 1, c[2] + 1))
        return 0;
    for (int dx = -1; dx <= 1; dx++) {
        int x = c[0] + dx;
        if ((unsigned)x >= n)
            continue;
        for (int dy = -1; dy <= 1; dy++) {
            int y = c[1] + dy;
            if ((unsigned)y >= n || (dx == 0 && dy == 0))
                continue;
            if (column_any(L, x, y, c[2] - 1, c[2] + 1))
                return 0;
        }
    }
    return 1;
}

/* log2 to within 5e-3 (the level only picks cells and a blend weight): the float's exponent plus a
 * quadratic in its mantissa. libm's log2f was 5 % of a render. */
static float fast_log2(float x)
{
    if (!(x > 1e-30f))
        return -100.0f;
    uint32_t i;
    memcpy(&i, &x, sizeof i);
    float e = (float)((int)((i >> 23) & 255u) - 128); /* the quadratic below is log2(m) + 1 */
    i = (i & 0x007fffffu) | 0x3f800000u;
    float m;
    memcpy(&m, &i, sizeof m); /* in [1, 2) */
    return e + (-0.34484843f * m + 2.02466578f) * m - 0.67487759f;
}

/* Distance along dir from the lattice point u (units of `level`) to the exit of its cell. */
static double cell_exit(const voxel_grid *g, int level, const double u[3], vec3 dir)
{
    double size = g->voxel_size_d * (double)(1u << level), best = INFINITY;
    for (int a = 0; a < 3; a++) {
        double d = v3_get(dir, a) / size;
        if (fabs(d) < 1e-30)
            continue;
        double c = floor(u[a]);
        double bound = d > 0.0 ? c + 1.0 : c;
        double t = (bound - u[a]) / d;
        best = t < best ? t : best; /* not fmin: a libm call on the hot path */
    }
    return best;
}

typedef struct {
    unsigned int covered[VX_MASK_WORDS];
    int count; /* bits set in covered */
    vec3 color;
} composite;

static float light_transmittance(const render_job *j, vec3 p, float r, float start, vec3 to_light, float distance,
                                 thread_counts *tc);

static void cached_transmittance(const render_job *j, vec3 p, float level, int lights, float *T, thread_counts *tc);

/* Marches cone c over [t, t_end] into comp. With shade, contributing elements are shaded (lights
 * with shadow cones when declared); without, only coverage accumulates (a light cone). */
static void march(const render_job *j, const cone *c, float t, float t_end, int shade, composite *comp,
                  thread_counts *tc)
{
    const voxel_grid *g = j->g;
    const vx_model *m = j->m;
    const scene *s = j->s;
    vx_query q;
    memset(&q, 0, sizeof q);
    q.ray_origin = c->org;
    q.ray_dir = c->dir;
    q.to_viewer = v3_scale(c->dir, -1.0f);
    q.effects = s->effects;
    q.grid = g;
    q.records = j->records;
    float vs = g->voxel_size;
    int top = g->levels - 1;
    int known_K = -1, known[3] = {0, 0, 0}; /* the last cell whose neighbourhood was non-empty */
    int K_skip = 0;                           /* the level the last jump used */
    for (int steps = 0; steps < CONE_MAX_ELEMENTS && t < t_end && comp->count < FULL_MASK; steps++) {
        float r = cone_radius(c, t + cone_radius(c, t));
        float tc_ = t + r;
        vec3 p = v3_madd(c->org, c->dir, tc_);
        float level = fast_log2(2.0f * r / vs);
        level = level > 0.0f ? (level < (float)top ? level : (float)top) : 0.0f;
        /* Empty-space skipping over the coarse levels with hysteresis (as grid_traverse's DDA):
         * start at the level the last jump used, descend while the neighbourhood is occupied,
         * climb while the coarser one is empty, jump out of the cell. K_min = the finest level
         * whose emptiness proves the element's stencil (floor(level) + 1) empty. */
        int K_min = (int)level + 1 <= top ? (int)level + 1 : top;
        int K = K_skip > K_min ? K_skip : K_min;
        double lat[3], u[3];
        grid_to_lattice(g, p, lat);
        int cell[3], empty = 0;
        for (;;) {
            double scale = 1.0 / (double)(1u << K);
            for (int a = 0; a < 3; a++) {
                u[a] = lat[a] * scale;
                cell[a] = (int)floor(u[a]);
            }
            /* Consecutive elements mostly share a cell: a neighbourhood found occupied stays so. */
            if (K == known_K && cell[0] == known[0] && cell[1] == known[1] && cell[2] == known[2])
                break;
            if (neighbourhood_empty(j, K, cell)) {
                empty = 1;
                break;
            }
            if (K == K_min) {
                known_K = K;
                memcpy(known, cell, sizeof known);
                break;
            }
            K--;
        }
        if (empty) {
            while (K < top) {
                int up[3] = {cell[0] >> 1, cell[1] >> 1, cell[2] >> 1};
                if (!neighbourhood_empty(j, K + 1, up))
                    break;
                K++;
                memcpy(cell, up, sizeof cell);
                for (int a = 0; a < 3; a++)
                    u[a] *= 0.5;
            }
            K_skip = K;
            double exit = cell_exit(g, K, u, c->dir);
            if (!(exit < INFINITY))
                break;
            t = tc_ + (float)exit + 1e-4f * vs * (float)(1u << K);
            continue;
        }
        K_skip = K_min;
        tc->voxel_visits++; /* one cone element evaluated */
        q.position = p;
        q.level = level;
        q.footprint = r;
        q.t0 = tc_ - r;
        q.t1 = tc_ + r;
        q.voxel_size = 2.0f * r;
        q.voxel_lo = v3_sub(p, v3(r, r, r));
        /* Lights unshadowed at first: most elements show nothing, and shadow cones are cast only
         * from those that add coverage. */
        q.light_count = 0;
        vec3 irr[VX_MAX_LIGHTS];
        float dist[VX_MAX_LIGHTS];
        if (shade) {
            q.light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
            for (int li = 0; li < q.light_count; li++) {
                light_at(&s->lights[li], p, &q.to_light[li], &irr[li], &dist[li]);
                q.irradiance[li] = irr[li];
            }
        }
        vx_answer a;
        uint64_t c0 = cycles();
        m->cone_element(&q, &a);
        tc->model_cycles += cycles() - c0;
        tc->model_evals++;
        int fresh = 0;
        for (int w = 0; w < VX_MASK_WORDS; w++)
            fresh += __builtin_popcount(a.mask[w] & ~comp->covered[w]);
        if (fresh > 0) {
            if (shade) {
                if ((s->effects & EFFECT_SHADOWS) && q.light_count > 0) {
                    float T[VX_MAX_LIGHTS];
                    int all_lit = 1;
                    /* From where the camera ray enters the element: the surface lies within the
                     * element (it adds coverage) but not before it (the previous one did not), so
                     * the entry is outside the surface and the light cone does not start inside it. */
                    vec3 entry = v3_madd(c->org, c->dir, tc_ - r);
                    if (j->light_cache)
                        cached_transmittance(j, entry, level, q.light_count, T, tc);
                    else
                        for (int li = 0; li < q.light_count; li++)
                            T[li] = light_transmittance(j, entry, r, 3.0f * r, q.to_light[li], dist[li], tc);
                    for (int li = 0; li < q.light_count; li++)
                        all_lit &= T[li] == 1.0f;
                    if (q.light_count == 1) {
                        /* Radiance is linear in the one light's irradiance. */
                        a.radiance = v3_scale(a.radiance, T[0]);
                    } else if (!all_lit) {
                        for (int li = 0; li < q.light_count; li++)
                            q.irradiance[li] = v3_scale(irr[li], T[li]);
                        vx_answer b;
                        c0 = cycles();
                        m->cone_element(&q, &b);
                        tc->model_cycles += cycles() - c0;
                        tc->model_evals++;
                        a.radiance = b.radiance;
                    }
                }
                comp->color = v3_madd(comp->color, a.radiance, (float)fresh / (float)FULL_MASK);
            }
            comp->count = 0;
            for (int w = 0; w < VX_MASK_WORDS; w++) {
                comp->covered[w] |= a.mask[w];
                comp->count += __builtin_popcount(comp->covered[w]);
            }
        }
        t = tc_ + r;
    }
}

/* Light cone from point p of an element of radius r: a cylinder of the element's width (the lights
 * are points or directions), starting past the element (its first element is centred 3 r away, as
 * the voxel tracer skips 1.5 voxel sizes) so that the surface it leaves does not shadow itself. */
static float light_transmittance(const render_job *j, vec3 p, float r, float start, vec3 to_light, float distance,
                                 thread_counts *tc)
{
    tc->shadow_rays++;
    cone c = {p, to_light, r, 0.0f, 0.0f, 1.0f, 1.0f, 0.125f * j->g->voxel_size};
    float t0, t1;
    if (!clip_to_grid(j->g, p, to_light, &t0, &t1))
        return 1.0f;
    composite comp;
    memset(&comp, 0, sizeof comp);
    march(j, &c, fmaxf(t0, start), fminf(t1, distance), 0, &comp, tc);
    return 1.0f - (float)comp.count / (float)FULL_MASK;
}

/* Every light's transmittance for an element entering the scene's surface at p on MIP level
 * `level`, through the light cache (cone_light_cache.h): the canonical light cones of the cell of
 * level floor(level) that holds p, cast from the cell's centre with the radius of an element of
 * level floor(level) + 1/2 (elements of that level are 1 to 2 cells wide). The centre is within
 * half a cell's diagonal of p, inside the light cone's width, so its shadow is the element's own
 * up to a fraction of its blur (MSE and SSIM against the ground truth move either way by a few
 * per cent; --no-cache casts every element's own cones). */
static void cached_transmittance(const render_job *j, vec3 p, float level, int lights, float *T, thread_counts *tc)
{
    const voxel_grid *g = j->g;
    int L = (int)level;
    double lat[3];
    grid_to_lattice(g, p, lat);
    int cell[3];
    for (int a = 0; a < 3; a++)
        cell[a] = (int)floor(lat[a] / (double)(1u << L));
    uint64_t key = cone_light_cache_key(L, cell[0] & 0xfffff, cell[1] & 0xfffff, cell[2] & 0xfffff);
    long slot = -1;
    if (cell[0] >= 0 && cell[1] >= 0 && cell[2] >= 0) { /* p lies in the grid's box */
        slot = cone_light_cache_slot(j->light_cache, key);
        if (cone_light_cache_get(j->light_cache, slot, T)) {
            tc->cache_hits++;
            return;
        }
    }
    vec3 centre = grid_cell_center(g, L, cell[0], cell[1], cell[2]);
    /* The element's radius at level L + 1/2, and its start (3 r, as light_transmittance's callers)
     * pushed out by half the cell's diagonal: the centre may lie that far below the surface that p
     * enters from outside, and a cone starting inside the surface would shadow itself. */
    float size = (float)ldexp(g->voxel_size_d, L);
    float r = 0.70710678f * size, start = 3.0f * r + 0.8660254f * size;
    for (int li = 0; li < lights; li++) {
        vec3 to_light, irr;
        float dist;
        light_at(&j->s->lights[li], centre, &to_light, &irr, &dist);
        T[li] = light_transmittance(j, centre, r, start, to_light, dist, tc);
    }
    cone_light_cache_put(j->light_cache, slot, T);
}

vec3 cone_trace_ray(const render_job *j, vec3 org, vec3 dir, thread_counts *tc)
{
    const scene *s = j->s;
    tc->rays++;
    /* (org, dir) is the pixel's centre ray from the lens centre (render_row): the cone covers the
     * pixel's footprint and, with depth of field, the lens by its width. */
    int dof = (s->effects & EFFECT_DOF) && s->camera.aperture_radius > 0.0f;
    /* spread is the pixel's half-width per unit distance; the cone gets the disk of the pixel's
     * area (radius 2/sqrt(pi) times that), which matches the ground truth's box filter best. */
    cone c = {org,
              dir,
              0.0f,
              j->spread * 1.12837917f,
              dof ? s->camera.aperture_radius : 0.0f,
              fmaxf(s->camera.focus_distance, 1e-6f),
              v3_dot(dir, s->camera.forward),
              0.125f * j->g->voxel_size};
    composite comp;
    memset(&comp, 0, sizeof comp);
    float t0, t1;
    if (clip_to_grid(j->g, org, dir, &t0, &t1))
        march(j, &c, t0, t1, 1, &comp, tc);
    return v3_madd(comp.color, s->background, 1.0f - (float)comp.count / (float)FULL_MASK);
}
