#include "bake.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "parallel.h"
#include "rng.h"
#include "shading.h"
#include "tribox.h"

#define PACKET 16
#define VOXELS_PER_ITEM 32

/* Slab test of the infinite line p + s d against the box: 1 and the interval when it crosses. */
static int line_box(vec3 p, vec3 d, vec3 lo, vec3 hi, float *s0, float *s1)
{
    float a = -INFINITY, b = INFINITY;
    for (int k = 0; k < 3; k++) {
        float pk = v3_get(p, k), dk = v3_get(d, k), l = v3_get(lo, k), h = v3_get(hi, k);
        if (fabsf(dk) < 1e-12f) {
            if (pk < l || pk > h)
                return 0;
            continue;
        }
        float u = (l - pk) / dk, v = (h - pk) / dk;
        if (u > v) {
            float t = u;
            u = v;
            v = t;
        }
        a = fmaxf(a, u);
        b = fminf(b, v);
    }
    *s0 = a;
    *s1 = b;
    return a < b;
}

void bake_generate_rays(const rt_scene *rt, const voxel_grid *g, size_t index, uint64_t seed, int n, vx_sample *out)
{
    int x, y, z;
    grid_coords(g, 0, index, &x, &y, &z);
    vec3 lo, hi;
    grid_cell_box(g, 0, x, y, z, &lo, &hi);
    vec3 c = v3_scale(v3_add(lo, hi), 0.5f);
    const scene *s = rt->scene;
    vec3 sc = v3_scale(v3_add(s->bounds_lo, s->bounds_hi), 0.5f);
    float radius = 0.5f * v3_length(v3_sub(s->bounds_hi, s->bounds_lo)) + 2.0f * g->voxel_size;
    rng r = rng_seed(seed, index);
    for (int i = 0; i < n; i++) {
        /* Direction uniform on the sphere. */
        float cz = 1.0f - 2.0f * rng_float(&r), phi = 2.0f * VX_PI * rng_float(&r);
        float sz = sqrtf(fmaxf(0.0f, 1.0f - cz * cz));
        vec3 d = v3(sz * cosf(phi), sz * sinf(phi), cz);
        vec3 t, b;
        v3_basis(d, &t, &b);
        /* The voxel's projection along d lies in the rectangle spanned by its corners' (t, b)
         * coordinates; sampling the rectangle and rejecting lines that miss the voxel gives points
         * uniform over the projection (the acceptance rate is at least 1/2). */
        float h = 0.5f * g->voxel_size;
        float ext_t = h * (fabsf(t.x) + fabsf(t.y) + fabsf(t.z)), ext_b = h * (fabsf(b.x) + fabsf(b.y) + fabsf(b.z));
        vec3 p;
        float s0 = 0, s1 = 0;
        int tries = 0;
        do {
            float u = (2.0f * rng_float(&r) - 1.0f) * ext_t, v = (2.0f * rng_float(&r) - 1.0f) * ext_b;
            p = v3_add(c, v3_add(v3_scale(t, u), v3_scale(b, v)));
        } while (!line_box(p, d, lo, hi, &s0, &s1) && ++tries < 64);
        if (tries == 64) { /* practically impossible; fall back to the line through the centre */
            p = c;
            line_box(p, d, lo, hi, &s0, &s1);
        }
        /* Back the origin up to outside the scene's bounding sphere. */
        float back = v3_dot(v3_sub(p, sc), d) + radius;
        vx_sample *o = &out[i];
        memset(o, 0, sizeof *o);
        o->origin = v3_madd(p, d, -back);
        o->dir = d;
        o->t_entry = back + s0;
        o->t_exit = back + s1;
        o->t_hit = INFINITY;
    }
}

void bake_trace(const rt_scene *rt, const voxel_grid *g, size_t index, vx_sample *samples, int n)
{
    int x, y, z;
    grid_coords(g, 0, index, &x, &y, &z);
    vec3 lo, hi;
    grid_cell_box(g, 0, x, y, z, &lo, &hi);
    /* Triangles lying on the voxel's faces are hit exactly at t_entry or t_exit: widen a little. */
    float slack = 1e-4f * g->voxel_size + rt->epsilon * 0.1f;
    const mesh *m = &rt->scene->mesh;
    for (int first = 0; first < n; first += PACKET) {
        int count = n - first < PACKET ? n - first : PACKET;
        struct RTCRayHit16 rh;
        int valid[PACKET] __attribute__((aligned(64)));
        for (int k = 0; k < PACKET; k++) {
            const vx_sample *sp = &samples[first + (k < count ? k : 0)];
            valid[k] = k < count ? -1 : 0;
            rh.ray.org_x[k] = sp->origin.x, rh.ray.org_y[k] = sp->origin.y, rh.ray.org_z[k] = sp->origin.z;
            rh.ray.dir_x[k] = sp->dir.x, rh.ray.dir_y[k] = sp->dir.y, rh.ray.dir_z[k] = sp->dir.z;
            rh.ray.tnear[k] = fmaxf(0.0f, sp->t_entry - slack);
            rh.ray.tfar[k] = INFINITY;
            rh.ray.time[k] = 0.0f;
            rh.ray.mask[k] = 0xffffffffu;
            rh.ray.id[k] = (unsigned)k;
            rh.ray.flags[k] = 0;
            rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        }
        struct RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        rtcIntersect16(valid, rt->bvh, &ctx, &rh);
        for (int k = 0; k < count; k++) {
            vx_sample *sp = &samples[first + k];
            if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
                sp->kind = VX_SAMPLE_MISS;
                continue;
            }
            unsigned prim = rh.hit.primID[k];
            sp->t_hit = rh.ray.tfar[k];
            surface_hit h;
            rt_surface(rt, prim, rh.hit.u[k], rh.hit.v[k], sp->origin, sp->dir, sp->t_hit, &h);
            sp->normal = h.normal;
            sp->specular = h.material->specular;
            sp->roughness = h.material->roughness;
            if (sp->t_hit <= sp->t_exit + slack) {
                sp->kind = h.front_facing ? VX_SAMPLE_INSIDE_FRONT : VX_SAMPLE_INSIDE_BACK;
                sp->own_triangle = 1;
                /* A double-sided surface seen from behind shades like a front face. */
                if (!h.front_facing && h.material->double_sided)
                    sp->kind = VX_SAMPLE_INSIDE_FRONT;
                sp->albedo = sp->kind == VX_SAMPLE_INSIDE_FRONT ? h.albedo : v3(0, 0, 0);
            } else {
                sp->kind = VX_SAMPLE_OUTSIDE;
                const uint32_t *tri = &m->indices[3 * (size_t)prim];
                sp->own_triangle = tribox_overlap(lo, hi, mesh_position(m, tri[0]), mesh_position(m, tri[1]),
                                                  mesh_position(m, tri[2]));
            }
        }
    }
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
    return m->uses_levels ? bake_level_offset(g, g->levels) : grid_count(g, 0);
}

typedef struct {
    const rt_scene *rt;
    const voxel_grid *g;
    const vx_model *m;
    const bake_options *o;
    unsigned char *records;
    vx_sample **scratch; /* per thread */
} bake_job;

static void bake_item(void *p, int64_t item, int thread)
{
    bake_job *j = p;
    size_t count = grid_count(j->g, 0);
    size_t first = (size_t)item * VOXELS_PER_ITEM;
    vx_sample *samples = j->scratch[thread];
    for (size_t i = first; i < first + VOXELS_PER_ITEM && i < count; i++) {
        bake_generate_rays(j->rt, j->g, i, j->o->seed, j->o->rays, samples);
        bake_trace(j->rt, j->g, i, samples, j->o->rays);
        vx_voxel v;
        grid_coords(j->g, 0, i, &v.x, &v.y, &v.z);
        vec3 hi;
        grid_cell_box(j->g, 0, v.x, v.y, v.z, &v.lo, &hi);
        v.index = (long long)i;
        v.size = j->g->voxel_size;
        v.effects = j->rt->scene->effects;
        j->m->bake_voxel(&v, samples, j->o->rays, j->records + i * j->m->voxel_bytes);
    }
}

int bake_run(const rt_scene *rt, const voxel_grid *g, const vx_model *m, const bake_options *o, void **records,
             bake_counts *counts, vx_err *e)
{
    if (o->rays < 1)
        return vx_fail(e, "--rays %d: expected at least 1 ray per voxel", o->rays);
    size_t nrec = bake_record_count(m, g);
    unsigned char *rec = calloc(nrec ? nrec : 1, m->voxel_bytes);
    int threads = parallel_threads(o->threads);
    vx_sample **scratch = calloc((size_t)threads, sizeof *scratch);
    int ok = rec && scratch;
    for (int t = 0; ok && t < threads; t++)
        ok = (scratch[t] = malloc(sizeof(vx_sample) * (size_t)o->rays)) != NULL;
    if (!ok) {
        for (int t = 0; scratch && t < threads; t++)
            free(scratch[t]);
        free(scratch);
        free(rec);
        return vx_fail(e, "out of memory for %zu voxel records of %zu bytes", nrec, m->voxel_bytes);
    }
    bake_job j = {rt, g, m, o, rec, scratch};
    size_t voxels = grid_count(g, 0);
    double t0 = now_seconds();
    parallel_for((int64_t)((voxels + VOXELS_PER_ITEM - 1) / VOXELS_PER_ITEM), threads, bake_item, &j,
                 o->progress ? "bake" : NULL);
    double t1 = now_seconds();
    for (int t = 0; t < threads; t++)
        free(scratch[t]);
    free(scratch);
    if (m->bake_finish && m->bake_finish(g, rec)) {
        free(rec);
        return vx_fail(e, "model %s: bake_finish failed", m->name);
    }
    counts->seconds = t1 - t0;
    counts->finish_seconds = now_seconds() - t1;
    counts->rays = (uint64_t)voxels * (uint64_t)o->rays;
    counts->voxels = voxels;
    *records = rec;
    return 0;
}
