/* The OpenCL voxel tracer: the C tracer (tracer/render.c) as two kernels, built from the same
 * portable sources. tracer/opencl_program.c assembles the program: tracer/cl/prelude.h, then the
 * model's cl_source header, then this file, with
 *   VX_CL_OPACITY, VX_CL_SHADE  the model's cl_opacity and cl_shade functions
 *   VX_CL_COMPOSITING           its VX_COMPOSITE_* rule (a constant, so each program keeps one rule)
 *   VX_CL_RECORD_BYTES          its voxel_bytes
 *   VX_CL_PARAMS_BYTES          sizeof(vx_cl_params) on the host
 * The traversal is grid_traverse_core.h, the rays camera.h's camera_ray, the random numbers rng.h,
 * the shading the model's own code: what is written here is only the tracer's control flow, which
 * mirrors render.c line for line (shadow_transmittance, gather_lights, evaluate, answer_for_voxel,
 * trace_ray, render_row) so that both backends give the same image.
 *
 * The shading cache: the C tracer caches each voxel's answer for the direction voxel -> camera the
 * first time a ray visits it; that answer depends only on the voxel, so vx_fill_cache computes it
 * up front for every non-empty voxel (one work-item each) and vx_render only reads it. */
#include "grid_traverse_core.h"
#include "model.h"
#include "render_params.h"
#include "rng.h"
#include "shading.h"

/* camera.h takes its `camera` type from scene.h, which is host-only (meshes, textures, files): mark
 * scene.h as included and give the name to vx_cl_camera, which declares the same fields. */
#define VX_SCENE_H
typedef vx_cl_camera camera;
#include "camera.h"

/* A mismatch between the host's and this compiler's layout would read garbage: refuse to build. */
typedef char vx_cl_params_size_matches_host[sizeof(vx_cl_params) == VX_CL_PARAMS_BYTES ? 1 : -1];

/* What a work-item needs while tracing: the parameters, the grid (level tables in private memory,
 * pointing into the buffers), the records, the cache and its counters. */
typedef struct {
    __global const vx_cl_params *P;
    const voxel_grid *g;
    __global const uchar *records;
    __global const vx_cl_cache *cache;
    uint count[VX_CL_COUNTERS];
} cl_job;

/* The grid as grid_core.h expects it: the tables of every level, rebuilt from buffer offsets. */
static void cl_grid(voxel_grid *g, __global const vx_cl_params *P, __global ulong *cols, __global ulong *bits,
                    __global uint *prefix, __global uint *coords0)
{
    g->n = P->n;
    g->origin = P->grid_origin;
    g->voxel_size = P->voxel_size;
    for (int a = 0; a < 3; a++)
        g->origin_d[a] = P->origin_d[a];
    g->voxel_size_d = P->voxel_size_d;
    g->levels = P->levels;
    for (int l = 0; l < GRID_MAX_LEVELS; l++) {
        grid_level *L = &g->level[l];
        int used = l < P->levels;
        L->n = used ? P->level_n[l] : 0;
        L->words_per_col = (L->n + 63) / 64;
        L->cols = used ? cols + P->level_cols[l] : 0;
        L->bits = used ? bits + P->level_words[l] : 0;
        L->prefix = used ? prefix + P->level_words[l] : 0;
        L->coords = l == 0 ? coords0 : 0;
        L->words = 0; /* unused by the lookups and the DDA */
        L->count = l == 0 ? (size_t)P->voxel_count : 0;
    }
}

static __global const void *cl_record(const cl_job *j, long index)
{
    return (__global const void *)(j->records + (size_t)index * VX_CL_RECORD_BYTES);
}

/* rt_light_at (tracer/rt.c), the same arithmetic. */
static void cl_light_at(__global const vx_cl_light *L, vec3 p, vec3 *to_light, vec3 *irradiance, float *distance)
{
    if (L->type == 0) {
        *to_light = L->direction;
        *irradiance = L->radiance;
        *distance = INFINITY;
        return;
    }
    vec3 d = v3_sub(L->position, p);
    float d2 = fmaxf(v3_dot(d, d), 1e-20f);
    *distance = sqrtf(d2);
    *to_light = v3_scale(d, 1.0f / *distance);
    *irradiance = v3_scale(L->radiance, 1.0f / d2);
}

/* truth_strata_sample (tracer/truth.c): sample i of sx * sy strata, jittered by (r1, r2). */
static void cl_strata_sample(int i, int sx, int sy, float r1, float r2, float *x, float *y)
{
    if (i < sx * sy) {
        *x = ((float)(i % sx) + r1) / (float)sx;
        *y = ((float)(i / sx) + r2) / (float)sy;
    } else {
        *x = r1;
        *y = r2;
    }
}

/* render.c's shadow_transmittance. */
static float cl_shadow_transmittance(cl_job *j, const vx_query *q, long self, vec3 p, vec3 to_light, float distance)
{
    const voxel_grid *g = j->g;
    float t_min = j->P->shadow_skip ? 1.5f * g->voxel_size : 0.0f;
    grid_iter it;
    grid_hit h;
    float T = 1.0f;
    j->count[VX_CL_SHADOW_RAYS]++;
    if (!gt_iter_init(&it, g, 0, p, to_light, t_min, distance))
        return 1.0f;
    vx_query sq = *q;
    sq.ray_origin = p;
    sq.ray_dir = to_light;
    sq.to_viewer = v3_scale(to_light, -1.0f);
    while (gt_iter_next(&it, &h)) {
        if (h.index == self)
            continue;
        sq.t0 = h.t0;
        sq.t1 = h.t1;
        vec3 hi;
        grid_cell_corners(g, 0, h.x, h.y, h.z, &sq.voxel_lo, &hi);
        float a = VX_CL_OPACITY(cl_record(j, h.index), &sq);
        T *= 1.0f - fminf(fmaxf(a, 0.0f), 1.0f);
        if (T < 1e-4f)
            return 0.0f;
    }
    return T;
}

/* render.c's gather_lights. */
static void cl_gather_lights(cl_job *j, vx_query *q, long self, vec3 c)
{
    __global const vx_cl_params *P = j->P;
    q->light_count = P->light_count < VX_MAX_LIGHTS ? P->light_count : VX_MAX_LIGHTS;
    for (int li = 0; li < q->light_count; li++) {
        vec3 dir, irr;
        float dist;
        cl_light_at(&P->lights[li], c, &dir, &irr, &dist);
        if (P->effects & VX_EFFECT_SHADOWS)
            irr = v3_scale(irr, cl_shadow_transmittance(j, q, self, c, dir, dist));
        q->to_light[li] = dir;
        q->irradiance[li] = irr;
    }
}

/* render.c's evaluate. */
static void cl_evaluate(cl_job *j, vx_query *q, long index, vec3 centre, vx_answer *a)
{
    __global const void *rec = cl_record(j, index);
    a->opacity = VX_CL_OPACITY(rec, q);
    a->radiance = v3(0.0f, 0.0f, 0.0f);
    for (int w = 0; w < VX_MASK_WORDS; w++)
        a->mask[w] = 0;
    j->count[VX_CL_EVALS]++;
    if (!(a->opacity > 0.0f))
        return;
    cl_gather_lights(j, q, index, centre);
    VX_CL_SHADE(rec, q, a);
}

/* The query answer_for_voxel starts from: zeroed, with the voxel's box, size and the effects. */
static void cl_query_for_voxel(const cl_job *j, int x, int y, int z, vx_query *q, vec3 *centre)
{
    vx_query zero = {0};
    *q = zero;
    vec3 hi;
    grid_cell_corners(j->g, 0, x, y, z, &q->voxel_lo, &hi);
    *centre = v3_scale(v3_add(q->voxel_lo, hi), 0.5f);
    q->voxel_size = j->g->voxel_size;
    q->effects = j->P->effects;
}

/* answer_for_voxel without the cache: the voxel as this ray sees it. */
static void cl_answer_uncached(cl_job *j, const grid_hit *h, vec3 org, vec3 dir, vx_answer *a)
{
    __global const vx_cl_params *P = j->P;
    vx_query q;
    vec3 centre;
    cl_query_for_voxel(j, h->x, h->y, h->z, &q, &centre);
    q.to_viewer = v3_scale(dir, -1.0f);
    q.ray_origin = org;
    q.ray_dir = dir;
    q.t0 = h->t0;
    q.t1 = h->t1;
    float tm = 0.5f * (h->t0 + h->t1);
    q.footprint = tm * P->spread;
    if ((P->effects & VX_EFFECT_DOF) && P->cam.aperture_radius > 0.0f)
        q.footprint += P->cam.aperture_radius * fabsf(tm - P->cam.focus_distance) / P->cam.focus_distance;
    cl_evaluate(j, &q, h->index, centre, a);
}

static void cl_answer(cl_job *j, const grid_hit *h, vec3 org, vec3 dir, vx_answer *a)
{
    if (!j->P->cache) {
        cl_answer_uncached(j, h, org, dir, a);
        return;
    }
    __global const vx_cl_cache *ce = &j->cache[h->index];
    j->count[VX_CL_HITS]++;
    a->radiance = v3(ce->radiance[0], ce->radiance[1], ce->radiance[2]);
    a->opacity = ce->opacity;
    for (int w = 0; w < VX_MASK_WORDS; w++)
        a->mask[w] = ce->mask[w];
}

/* render.c's trace_ray; the compositing rule is a constant of the program. */
static vec3 cl_trace_ray(cl_job *j, vec3 org, vec3 dir)
{
    vec3 color = v3(0.0f, 0.0f, 0.0f);
    float A = 0.0f;
    uint covered[VX_MASK_WORDS] = {0, 0, 0, 0};
    int done = 0;
    grid_iter it;
    grid_hit h;
    if (gt_iter_init(&it, j->g, 0, org, dir, 0.0f, INFINITY)) {
        while (!done && gt_iter_next(&it, &h)) {
            j->count[VX_CL_VISITS]++;
            vx_answer a;
            cl_answer(j, &h, org, dir, &a);
            float alpha = fminf(fmaxf(a.opacity, 0.0f), 1.0f);
            if (!(alpha > 0.0f))
                continue;
            if (VX_CL_COMPOSITING == VX_COMPOSITE_FIRST_HIT) {
                color = a.radiance;
                A = 1.0f;
                done = 1;
            } else if (VX_CL_COMPOSITING == VX_COMPOSITE_ALPHA) {
                color = v3_madd(color, a.radiance, (1.0f - A) * alpha);
                A += (1.0f - A) * alpha;
                done = A >= j->P->stop_opacity;
            } else { /* VX_COMPOSITE_COVERAGE */
                int fresh = 0, total = 0;
                for (int w = 0; w < VX_MASK_WORDS; w++) {
                    fresh += (int)popcount(a.mask[w] & ~covered[w]);
                    covered[w] |= a.mask[w];
                    total += (int)popcount(covered[w]);
                }
                color = v3_madd(color, a.radiance, (float)fresh / (32.0f * VX_MASK_WORDS));
                A = (float)total / (32.0f * VX_MASK_WORDS);
                done = total == 32 * VX_MASK_WORDS;
            }
        }
    }
    return v3_madd(color, j->P->background, 1.0f - A);
}

/* One work-item per non-empty level-0 voxel: its answer for the direction voxel -> camera, as
 * answer_for_voxel computes it on a cache miss. counts: VX_CL_SHADOW_RAYS and VX_CL_EVALS per voxel
 * (2 words). */
__kernel void vx_fill_cache(__global const vx_cl_params *P, __global ulong *cols, __global ulong *bits,
                            __global uint *prefix, __global uint *coords0, __global const uchar *records,
                            __global vx_cl_cache *cache, __global uint *counts, int count)
{
    int i = (int)get_global_id(0);
    if (i >= count)
        return;
    voxel_grid g;
    cl_grid(&g, P, cols, bits, prefix, coords0);
    cl_job j = {P, &g, records, cache, {0, 0, 0, 0}};
    uint c = coords0[i];
    vx_query q;
    vec3 centre;
    cl_query_for_voxel(&j, (int)(c >> 20), (int)((c >> 10) & 1023u), (int)(c & 1023u), &q, &centre);
    vec3 to_cam = v3_sub(P->cam.position, centre);
    float dist = v3_length(to_cam);
    /* The C tracer falls back on the first visiting ray's direction when the camera sits exactly at
     * the voxel's centre; there is no such ray here, the view direction stands in. */
    q.to_viewer = v3_normalize_or(to_cam, v3_scale(P->cam.forward, -1.0f));
    q.ray_dir = v3_scale(q.to_viewer, -1.0f);
    q.ray_origin = P->cam.position;
    q.t0 = dist - 0.5f * g.voxel_size;
    q.t1 = dist + 0.5f * g.voxel_size;
    q.footprint = dist * P->spread;
    vx_answer a;
    cl_evaluate(&j, &q, i, centre, &a);
    __global vx_cl_cache *ce = &cache[i];
    ce->radiance[0] = a.radiance.x;
    ce->radiance[1] = a.radiance.y;
    ce->radiance[2] = a.radiance.z;
    ce->opacity = a.opacity;
    for (int w = 0; w < VX_MASK_WORDS; w++)
        ce->mask[w] = a.mask[w];
    counts[2 * i] = j.count[VX_CL_SHADOW_RAYS];
    counts[2 * i + 1] = j.count[VX_CL_EVALS];
}

/* One work-item per pixel: render.c's render_row for one pixel (same random stream, strata, rays
 * and box filter). counts: VX_CL_COUNTERS words per pixel. */
__kernel void vx_render(__global const vx_cl_params *P, __global ulong *cols, __global ulong *bits,
                        __global uint *prefix, __global const uchar *records, __global const vx_cl_cache *cache,
                        __global float *image, __global uint *counts, int pixels)
{
    int pix = (int)get_global_id(0);
    if (pix >= pixels)
        return;
    voxel_grid g;
    cl_grid(&g, P, cols, bits, prefix, 0);
    cl_job j = {P, &g, records, cache, {0, 0, 0, 0}};
    int width = P->width, height = P->height, spp = P->spp;
    int px = pix % width, py = pix / width;
    int dof = (P->effects & VX_EFFECT_DOF) != 0;
    camera cam = P->cam;
    rng r = rng_seed(P->seed, (uint64_t)py * (uint64_t)width + (uint64_t)px);
    vec3 sum = v3(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < spp; i++) {
        float sx, sy, lu = 0, lv = 0;
        float r1 = rng_float(&r), r2 = rng_float(&r);
        cl_strata_sample(i, P->strata_x, P->strata_y, r1, r2, &sx, &sy);
        if (dof) {
            lu = rng_float(&r);
            lv = rng_float(&r);
        }
        vec3 org, dir;
        camera_ray(&cam, width, height, (float)px + sx, (float)py + sy, lu, lv, dof, &org, &dir);
        sum = v3_add(sum, cl_trace_ray(&j, org, dir));
    }
    __global float *dst = &image[3 * (size_t)pix];
    dst[0] = sum.x / (float)spp;
    dst[1] = sum.y / (float)spp;
    dst[2] = sum.z / (float)spp;
    for (int k = 0; k < VX_CL_COUNTERS; k++)
        counts[VX_CL_COUNTERS * (size_t)pix + k] = j.count[k];
}
