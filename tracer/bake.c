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

void bake_generate_rays(const rt_scene *rt, const voxel_grid *g, size_t index, uint64_t seed, int n, vx_sample *out)
{
    int x, y, z;
    grid_coords(g, 0, index, &x, &y, &z);
    vec3 lo, hi;
    grid_cell_box(g, 0, x, y, z, &lo, &hi);
    float blo[3] = {lo.x, lo.y, lo.z}, bhi[3] = {hi.x, hi.y, hi.z};
    const scene *s = rt->scene;
    vec3 sc = v3_scale(v3_add(s->bounds_lo, s->bounds_hi), 0.5f);
    float radius = 0.5f * v3_length(v3_sub(s->bounds_hi, s->bounds_lo)) + 2.0f * g->voxel_size;
    rng r = rng_seed(seed, index);
    for (int i = 0; i < n; i++) {
        /* Direction uniform on the sphere. */
        float cz = 1.0f - 2.0f * rng_float(&r), phi = 2.0f * VX_PI * rng_float(&r);
        float sz = sqrtf(fmaxf(0.0f, 1.0f - cz * cz));
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
        o->own_triangle = 0;
        o->normal = o->albedo = v3(0, 0, 0);
        o->specular = o->roughness = 0.0f;
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
    /* Rays of one voxel that pass it often hit the same few triangles behind it: remember the
     * last answers of the (comparatively costly) triangle/voxel overlap test. */
    enum { OWN_CACHE = 8 };
    unsigned own_prim[OWN_CACHE];
    int own_result[OWN_CACHE], own_next = 0;
    for (int c = 0; c < OWN_CACHE; c++)
        own_prim[c] = RTC_INVALID_GEOMETRY_ID;
    for (int first = 0; first < n; first += PACKET) {
        int count = n - first < PACKET ? n - first : PACKET;
        struct RTCRayHit16 rh;
        int valid[PACKET] __attribute__((aligned(64)));
        for (int k = 0; k < PACKET; k++) {
            const vx_sample *sp = &samples[first + (k < count ? k : 0)];
            valid[k] = k < count ? -1 : 0;
            rt_packet_rayhit(&rh, k, sp->origin, sp->dir, fmaxf(0.0f, sp->t_entry - slack), INFINITY);
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
            if (sp->t_hit > sp->t_exit + slack) {
                /* Past the voxel: models only ask whether the triangle is one of the voxel's own
                 * (Brito et al.'s per-voxel list). Bounding boxes settle most cases before the SAT. */
                sp->kind = VX_SAMPLE_OUTSIDE;
                int cached = -1;
                for (int c = 0; c < OWN_CACHE; c++)
                    if (own_prim[c] == prim)
                        cached = own_result[c];
                if (cached < 0) {
                    const uint32_t *tri = &m->indices[3 * (size_t)prim];
                    vec3 a = mesh_position(m, tri[0]), b = mesh_position(m, tri[1]), c = mesh_position(m, tri[2]);
                    vec3 tlo = v3_min(a, v3_min(b, c)), thi = v3_max(a, v3_max(b, c));
                    cached = tlo.x <= hi.x && thi.x >= lo.x && tlo.y <= hi.y && thi.y >= lo.y && tlo.z <= hi.z &&
                             thi.z >= lo.z && tribox_overlap(lo, hi, a, b, c);
                    own_prim[own_next] = prim;
                    own_result[own_next] = cached;
                    own_next = (own_next + 1) % OWN_CACHE;
                }
                sp->own_triangle = cached;
                continue;
            }
            surface_hit h;
            rt_surface(rt, prim, rh.hit.u[k], rh.hit.v[k], sp->origin, sp->dir, sp->t_hit, &h);
            sp->normal = h.normal;
            sp->specular = h.material->specular;
            sp->roughness = h.material->roughness;
            sp->own_triangle = 1;
            /* A double-sided surface seen from behind shades like a front face. */
            sp->kind = h.front_facing || h.material->double_sided ? VX_SAMPLE_INSIDE_FRONT : VX_SAMPLE_INSIDE_BACK;
            sp->albedo = sp->kind == VX_SAMPLE_INSIDE_FRONT ? h.albedo : v3(0, 0, 0);
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
