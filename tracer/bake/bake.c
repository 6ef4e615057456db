#include "bake.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "animation.h"
#include "bake_params.h"
#include "cycles.h"
#include "grid_scene.h"
#include "instancing.h"
#include "parallel.h"
#include "prefault.h"
#include "rng.h"
#include "rt_instances.h"
#include "scene_tris.h"
#include "shading.h"
#include "tribox.h"

#define OWN_STACK 64 /* own triangles of a voxel kept on the stack; more go to the heap */
#define VOXELS_PER_ITEM 32

void bake_generate_rays(const rt_scene *rt, const voxel_grid *g, size_t index, uint64_t seed, int n, vx_sample *out)
{
    int x, y, z;
    grid_coords(g, 0, index, &x, &y, &z);
    vec3 lo, hi;
    grid_cell_corners(g, 0, x, y, z, &lo, &hi);
    float blo[3] = {lo.x, lo.y, lo.z}, bhi[3] = {hi.x, hi.y, hi.z};
    const scene *s = rt->scene;
    vec3 sc = v3_scale(v3_add(s->bounds_lo, s->bounds_hi), 0.5f);
    float radius = 0.5f * v3_length(v3_sub(s->bounds_hi, s->bounds_lo)) + 2.0f * g->voxel_size;
    rng r = rng_seed(seed, index);
    for (int i = 0; i < n; i++) {
        /* Direction uniform on the sphere. */
        float cz = 1.0f - 2.0f * rng_float(&r), phi = 2.0f * VX_PI * rng_float(&r);
        float sz = sqrtf(vx_fmaxf(0.0f, 1.0f - cz * cz));
        float d[3] = {sz * cosf(phi), sz * sinf(phi), cz};
        /* Lines uniform over the voxel's projection along d, without rejection: every such line
         * enters the cube through exactly one face, and face k's share of the projected area is
         * |d_k| / (|d_x| + |d_y| + |d_z|); within that face the entry point is uniform. */
        float w0 = fabsf(d[0]), w1 = fabsf(d[1]), w2 = fabsf(d[2]);
        float pick = rng_float(&r) * (w0 + w1 + w2);
        int face = pick < w0 ? 0 : (pick < w0 + w1 ? 1 : 2);
        float p[3];
        float u1 = rng_float(&r), u2 = rng_float(&r);
        int a1 = (face + 1) % 3, a2 = (face + 2) % 3;
        p[face] = d[face] > 0.0f ? blo[face] : bhi[face];
        p[a1] = blo[a1] + u1 * (bhi[a1] - blo[a1]);
        p[a2] = blo[a2] + u2 * (bhi[a2] - blo[a2]);
        /* Exit: the nearest far-side plane. */
        float s_exit = INFINITY;
        for (int k = 0; k < 3; k++)
            if (d[k] != 0.0f) {
                float sk = ((d[k] > 0.0f ? bhi[k] : blo[k]) - p[k]) / d[k];
                s_exit = sk < s_exit ? sk : s_exit;
            }
        if (!(s_exit >= 0.0f))
            s_exit = 0.0f;
        vec3 dir = v3(d[0], d[1], d[2]), entry = v3(p[0], p[1], p[2]);
        /* Back the origin up to outside the scene's bounding sphere. */
        float back = v3_dot(v3_sub(entry, sc), dir) + radius;
        vx_sample *o = &out[i];
        o->origin = v3_madd(entry, dir, -back);
        o->dir = dir;
        o->t_entry = back;
        o->t_exit = back + s_exit;
        o->t_hit = INFINITY;
        /* The rest is filled by bake_trace. */
        o->kind = VX_SAMPLE_MISS;
        o->double_sided = o->back_side = 0;
        o->normal = o->albedo = v3(0, 0, 0);
        o->specular = o->roughness = 0.0f;
    }
}

/* The voxel's own triangles (Brito et al.'s per-voxel list), prepared for ray tests in double
 * relative to the voxel's centre: the rays start outside the scene, and a float test there would
 * lose the voxel's scale. `number` is the triangle's scene_tris.h number, (inst, prim) what
 * rt_surface takes. */
typedef struct {
    double p0[3], e1[3], e2[3];
    double c[3], r2; /* a sphere holding the triangle (centroid, squared radius): a quick miss */
    size_t number;
    unsigned inst, prim;
} own_triangle;

typedef struct {
    const scene *s;
    double lo[3], hi[3], centre[3]; /* the voxel's box, widened by the slack */
    own_triangle *tri;
    int count, cap, heap;
} own_list;

/* The point query (rt_query_sphere) hands over every triangle whose bounds come near the voxel's
 * bounding sphere, the copies' included; the exact closed triangle/box test on the world corners
 * (the grid's own notion of overlap, touching counts; its first axes are the box's, a bounding-box
 * rejection) keeps the voxel's triangles. */
static void own_collect(void *user, unsigned inst, unsigned prim)
{
    own_list *o = user;
    const scene *s = o->s;
    float c[9];
    size_t number = prim;
    if (inst != RTC_INVALID_GEOMETRY_ID) {
        const inst_instance *I = &s->inst->inst[inst];
        inst_corners(s->inst, I, prim, c);
        number = s->mesh.triangle_count + I->offset + prim;
    } else {
        const uint32_t *idx = &s->mesh.indices[3 * (size_t)prim];
        for (int k = 0; k < 3; k++)
            memcpy(&c[3 * k], &s->mesh.positions[3 * (size_t)idx[k]], 3 * sizeof(float));
    }
    double v[3][3];
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++)
            v[k][a] = c[3 * k + a];
    if (!tribox_overlap_d(o->lo, o->hi, v[0], v[1], v[2]))
        return;
    if (o->count == o->cap) {
        int cap = o->cap * 2;
        own_triangle *t = o->heap ? realloc(o->tri, sizeof *t * (size_t)cap) : malloc(sizeof *t * (size_t)cap);
        if (!t)
            return; /* out of memory: the voxel keeps the triangles gathered so far */
        if (!o->heap)
            memcpy(t, o->tri, sizeof *t * (size_t)o->count);
        o->heap = 1;
        o->tri = t;
        o->cap = cap;
    }
    own_triangle *t = &o->tri[o->count++];
    for (int a = 0; a < 3; a++) {
        t->p0[a] = v[0][a] - o->centre[a];
        t->e1[a] = v[1][a] - v[0][a];
        t->e2[a] = v[2][a] - v[0][a];
        t->c[a] = (v[0][a] + v[1][a] + v[2][a]) / 3.0 - o->centre[a];
    }
    t->r2 = 0;
    for (int k = 0; k < 3; k++) {
        double d2 = 0;
        for (int a = 0; a < 3; a++)
            d2 += (v[k][a] - o->centre[a] - t->c[a]) * (v[k][a] - o->centre[a] - t->c[a]);
        t->r2 = d2 > t->r2 ? d2 : t->r2;
    }
    t->number = number;
    t->inst = inst;
    t->prim = prim;
}

static int by_number(const void *a, const void *b)
{
    size_t x = ((const own_triangle *)a)->number, y = ((const own_triangle *)b)->number;
    return (x > y) - (x < y);
}

/* Closest crossing of the line o + t d (o relative to the voxel's centre) with the own triangles:
 * Moller-Trumbore with inclusive edges (a line through a shared edge hits both sides; either gives
 * the same t). Returns the index of the triangle, or -1; t, u, v as Embree reports them. A voxel of
 * a dense forest lists thousands of leaves, most far from any one line: the line's distance to
 * each triangle's bounding sphere skips those first, with a margin far above the rounding of that
 * distance, so that the test only ever skips triangles Moller-Trumbore would reject. */
static int own_closest_hit(const own_list *o, const double org[3], const double d[3], double *t_out, float *u_out,
                           float *v_out)
{
    int best = -1;
    double best_t = INFINITY, dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    for (int i = 0; i < o->count; i++) {
        const own_triangle *tr = &o->tri[i];
        double w[3] = {tr->c[0] - org[0], tr->c[1] - org[1], tr->c[2] - org[2]};
        double x[3] = {w[1] * d[2] - w[2] * d[1], w[2] * d[0] - w[0] * d[2], w[0] * d[1] - w[1] * d[0]};
        double x2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2], w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        if (x2 > (tr->r2 * 1.000001 + 1e-12 * w2) * dd) /* |w x d|^2 / |d|^2: the line's squared distance */
            continue;
        double p[3] = {d[1] * tr->e2[2] - d[2] * tr->e2[1], d[2] * tr->e2[0] - d[0] * tr->e2[2],
                       d[0] * tr->e2[1] - d[1] * tr->e2[0]};
        double det = tr->e1[0] * p[0] + tr->e1[1] * p[1] + tr->e1[2] * p[2];
        if (det == 0.0 || !isfinite(det))
            continue; /* the line lies in the triangle's plane (or the triangle has no area) */
        double inv = 1.0 / det;
        double s[3] = {org[0] - tr->p0[0], org[1] - tr->p0[1], org[2] - tr->p0[2]};
        double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv;
        if (u < 0.0 || u > 1.0)
            continue;
        double q[3] = {s[1] * tr->e1[2] - s[2] * tr->e1[1], s[2] * tr->e1[0] - s[0] * tr->e1[2],
                       s[0] * tr->e1[1] - s[1] * tr->e1[0]};
        double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
        if (v < 0.0 || u + v > 1.0)
            continue;
        double t = (tr->e2[0] * q[0] + tr->e2[1] * q[1] + tr->e2[2] * q[2]) * inv;
        if (t > 0.0 && t < best_t) {
            best_t = t;
            best = i;
            *u_out = (float)u;
            *v_out = (float)v;
        }
    }
    *t_out = best_t;
    return best;
}

void bake_trace(const rt_scene *rt, const voxel_grid *g, size_t index, vx_sample *samples, int n)
{
    int x, y, z;
    grid_coords(g, 0, index, &x, &y, &z);
    vec3 lo, hi;
    grid_cell_corners(g, 0, x, y, z, &lo, &hi);
    /* Triangles lying on the voxel's faces are hit exactly at t_entry or t_exit: widen a little. */
    float slack = 1e-4f * g->voxel_size + rt->epsilon * 0.1f;
    own_triangle stack[OWN_STACK];
    own_list own = {.s = rt->scene, .tri = stack, .cap = OWN_STACK};
    float flo[3] = {lo.x, lo.y, lo.z}, fhi[3] = {hi.x, hi.y, hi.z};
    for (int a = 0; a < 3; a++) {
        own.lo[a] = (double)flo[a] - slack;
        own.hi[a] = (double)fhi[a] + slack;
        own.centre[a] = 0.5 * ((double)flo[a] + (double)fhi[a]);
    }
    float centre[3] = {(float)own.centre[0], (float)own.centre[1], (float)own.centre[2]};
    rt_query_sphere(rt, centre, 0.8660254f * (float)(own.hi[0] - own.lo[0]) * 1.001f, own_collect, &own);
    /* In the scene's triangle order, whatever order the BVH's traversal met them in: a line through
     * an edge two triangles share meets both at the same t, and the first listed wins, so the order
     * decides which one's normal and colour the sample gets. Ordered this way, an instanced scene
     * and its written-out form (whose BVHs differ) classify every sample identically. */
    qsort(own.tri, (size_t)own.count, sizeof *own.tri, by_number);
    for (int i = 0; i < n; i++) {
        vx_sample *sp = &samples[i];
        double org[3] = {(double)sp->origin.x - own.centre[0], (double)sp->origin.y - own.centre[1],
                         (double)sp->origin.z - own.centre[2]};
        double d[3] = {sp->dir.x, sp->dir.y, sp->dir.z}, t;
        float u = 0.0f, v = 0.0f;
        int hit = own_closest_hit(&own, org, d, &t, &u, &v);
        if (hit < 0) {
            sp->kind = VX_SAMPLE_MISS; /* case (c) */
            continue;
        }
        sp->t_hit = (float)t;
        if (!(sp->t_hit >= sp->t_entry - slack && sp->t_hit <= sp->t_exit + slack)) {
            sp->kind = VX_SAMPLE_OUTSIDE; /* case (b): the closest own triangle is met outside the voxel */
            continue;
        }
        surface_hit h;
        const own_triangle *ot = &own.tri[hit];
        if (ot->inst != RTC_INVALID_GEOMETRY_ID && rt->scene->inst->inst[ot->inst].mirror) {
            float tmp = u; /* (u, v) on the copy's reversed winding -> on the prototype's */
            u = v, v = tmp;
        }
        rt_surface(rt, ot->inst, ot->prim, u, v, sp->origin, sp->dir, sp->t_hit, &h);
        sp->normal = h.normal;
        sp->specular = h.material->specular;
        sp->roughness = h.material->roughness;
        sp->double_sided = h.material->double_sided;
        sp->back_side = !h.front_facing;
        /* Case (a). A double-sided surface seen from behind shades like a front face. */
        sp->kind = h.front_facing || h.material->double_sided ? VX_SAMPLE_INSIDE_FRONT : VX_SAMPLE_INSIDE_BACK;
        sp->albedo = sp->kind == VX_SAMPLE_INSIDE_FRONT ? h.albedo : v3(0, 0, 0);
    }
    if (own.heap)
        free(own.tri);
}

size_t bake_level_offset(const voxel_grid *g, int level)
{
    size_t off = 0;
    for (int l = 0; l < level; l++)
        off += grid_count(g, l);
    return off;
}

size_t bake_record_count(const vx_model *m, const voxel_grid *g)
{
    return m->record.levels ? bake_level_offset(g, g->levels) : grid_count(g, 0);
}

typedef struct {
    const rt_scene *rt;
    const voxel_grid *g;
    int count; /* models baked from the same samples */
    const vx_model *const *m;
    const bake_options *o;
    const struct vx_bake_params *params; /* one per model */
    unsigned char **records;             /* one per model */
    vx_sample **scratch;                 /* per thread */
    uint64_t *cycles;                    /* per thread, BAKE_CYCLE_STRIDE apart: see bake_item */
} bake_job;

/* Each thread's cycle counts: [0] the whole of its items, [1 + k] model k's bake_voxel calls (the
 * rest of [0] is the samples' part). At least a cache line (8 words) between the words two threads
 * write, so that the counting does not make them fight over a line. */
#define BAKE_CYCLE_STRIDE 32
_Static_assert(BAKE_CYCLE_STRIDE >= 1 + BAKE_MAX_MODELS + 8, "a thread's counts and a line of space");

static void bake_item(void *p, int64_t item, int thread)
{
    bake_job *j = p;
    size_t count = grid_count(j->g, 0);
    size_t first = (size_t)item * VOXELS_PER_ITEM;
    vx_sample *samples = j->scratch[thread];
    uint64_t *cyc = j->cycles + (size_t)thread * BAKE_CYCLE_STRIDE;
    uint64_t c_item = cycles();
    for (size_t i = first; i < first + VOXELS_PER_ITEM && i < count; i++) {
        bake_generate_rays(j->rt, j->g, i, j->o->seed, j->o->rays, samples);
        bake_trace(j->rt, j->g, i, samples, j->o->rays);
        vx_voxel v;
        grid_coords(j->g, 0, i, &v.x, &v.y, &v.z);
        vec3 hi;
        grid_cell_corners(j->g, 0, v.x, v.y, v.z, &v.lo, &hi);
        v.index = (long long)i;
        v.size = j->g->voxel_size;
        v.effects = j->rt->scene->effects;
        /* Every model reads the same samples (const: none can change them for the next). */
        for (int k = 0; k < j->count; k++) {
            v.params = &j->params[k];
            uint64_t c0 = cycles();
            j->m[k]->bake_voxel(&v, samples, j->o->rays, j->records[k] + i * j->m[k]->record.bytes);
            cyc[1 + k] += cycles() - c0;
        }
    }
    cyc[0] += cycles() - c_item;
}

static void free_all(void **p, int n)
{
    for (int k = 0; p && k < n; k++)
        free(p[k]);
}

int bake_run_models(const rt_scene *rt, const voxel_grid *g, int count, const vx_model *const *m,
                    const struct vx_bake_params *params, const bake_options *o, void **records, bake_counts *counts,
                    vx_err *e)
{
    if (o->rays < 1)
        return vx_fail(e, "--rays %d: expected at least 1 ray per voxel", o->rays);
    if (count < 1 || count > BAKE_MAX_MODELS)
        return vx_fail(e, "%d models in one bake: expected 1..%d", count, BAKE_MAX_MODELS);
    unsigned char *rec[BAKE_MAX_MODELS] = {0};
    int threads = parallel_threads(o->threads);
    vx_sample **scratch = calloc((size_t)threads, sizeof *scratch);
    uint64_t *cyc = calloc((size_t)threads * BAKE_CYCLE_STRIDE, sizeof *cyc);
    int ok = scratch != NULL && cyc != NULL, failed = -1;
    for (int k = 0; ok && k < count; k++) {
        size_t nrec = bake_record_count(m[k], g);
        ok = (rec[k] = calloc(nrec ? nrec : 1, m[k]->record.bytes)) != NULL;
        /* Mapped now: pages first written by the bake threads fault one by one (prefault.h). */
        if (ok)
            vx_populate(rec[k], (nrec ? nrec : 1) * m[k]->record.bytes);
        failed = ok ? failed : k;
    }
    for (int t = 0; ok && t < threads; t++)
        ok = (scratch[t] = malloc(sizeof(vx_sample) * (size_t)o->rays)) != NULL;
    if (!ok) {
        free_all((void **)scratch, threads);
        free(scratch);
        free(cyc);
        free_all((void **)rec, count);
        if (failed >= 0)
            return vx_fail(e, "out of memory for %zu voxel records of %zu bytes", bake_record_count(m[failed], g),
                           m[failed]->record.bytes);
        return vx_fail(e, "out of memory for the bake's samples (%d rays)", o->rays);
    }
    bake_job j = {rt, g, count, m, o, params, rec, scratch, cyc};
    size_t voxels = grid_count(g, 0);
    parallel_prestart(threads); /* before the clock (parallel.h) */
    double t0 = now_seconds();
    parallel_for((int64_t)((voxels + VOXELS_PER_ITEM - 1) / VOXELS_PER_ITEM), threads, bake_item, &j,
                 o->progress ? "bake" : NULL);
    double t1 = now_seconds();
    free_all((void **)scratch, threads);
    free(scratch);
    /* The pass's wall time split in the proportions of the threads' cycles (the threads ran side by
     * side for the whole pass, so shares of their summed cycles are shares of the wall time). */
    uint64_t all = 0, own[BAKE_MAX_MODELS] = {0};
    for (int t = 0; t < threads; t++) {
        all += cyc[(size_t)t * BAKE_CYCLE_STRIDE];
        for (int k = 0; k < count; k++)
            own[k] += cyc[(size_t)t * BAKE_CYCLE_STRIDE + 1 + (size_t)k];
    }
    free(cyc);
    uint64_t models = 0;
    for (int k = 0; k < count; k++)
        models += own[k];
    double pass = t1 - t0, per_cycle = all ? pass / (double)all : 0.0;
    double sampling = models <= all ? (double)(all - models) * per_cycle : 0.0;
    for (int k = 0; k < count; k++) {
        double f0 = now_seconds();
        if (m[k]->bake_finish && m[k]->bake_finish(g, rec[k], &params[k])) {
            free_all((void **)rec, count);
            return vx_fail(e, "model %s: bake_finish failed", m[k]->name);
        }
        counts[k].pass_seconds = pass;
        counts[k].sampling_seconds = sampling;
        /* Alone: exactly the pass (its cycles are all of them). */
        counts[k].seconds = count == 1 ? pass : sampling + (double)own[k] * per_cycle;
        counts[k].finish_seconds = now_seconds() - f0;
        counts[k].rays = (uint64_t)voxels * (uint64_t)o->rays;
        counts[k].voxels = voxels;
    }
    for (int k = 0; k < count; k++)
        records[k] = rec[k];
    return 0;
}

int bake_run(const rt_scene *rt, const voxel_grid *g, const vx_model *m, const bake_options *o, void **records,
             bake_counts *counts, vx_err *e)
{
    struct vx_bake_params params;
    if (o->params_set)
        params = o->params;
    else
        bake_params_defaults(m, &params);
    return bake_run_models(rt, g, 1, &m, &params, o, records, counts, e);
}

int bake_scene_models(const scene *s, int count, const vx_model *const *m, const struct vx_bake_params *params,
                      int res, const bake_options *o, voxel_grid *g, void **records, bake_counts *counts,
                      double *grid_seconds, vx_err *e)
{
    parallel_prestart(parallel_threads(o->threads)); /* before the grid's clock (parallel.h) */
    double t0 = now_seconds();
    double lo[3], hi[3]; /* an animated scene: one lattice for every frame */
    int animated = anim_grid_bounds(s, lo, hi);
    if (grid_build_scene(g, s, res, animated ? lo : NULL, animated ? hi : NULL, e))
        return -1;
    *grid_seconds = now_seconds() - t0;
    rt_scene rt;
    if (rt_build(&rt, s, e)) {
        grid_free(g);
        return -1;
    }
    int rc = bake_run_models(&rt, g, count, m, params, o, records, counts, e);
    rt_free(&rt);
    if (rc)
        grid_free(g);
    return rc;
}

int bake_scene(const scene *s, const vx_model *m, int res, const bake_options *o, voxel_grid *g, void **records,
               bake_counts *counts, double *grid_seconds, vx_err *e)
{
    struct vx_bake_params params;
    if (o->params_set)
        params = o->params;
    else
        bake_params_defaults(m, &params);
    return bake_scene_models(s, 1, &m, &params, res, o, g, records, counts, grid_seconds, e);
}
