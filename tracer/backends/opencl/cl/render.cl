/* The OpenCL voxel tracer: the C tracer (tracer/render/render.c) as one kernel, built from the same
 * portable sources. tracer/backends/opencl/opencl_program.c assembles the program: tracer/backends/opencl/cl/prelude.h, then the
 * model's cl_source header, then this file, with
 *   VX_CL_OPACITY, VX_CL_SHADE  the model's cl_opacity and cl_shade functions
 *   VX_CL_COMPOSITING           its VX_COMPOSITE_* rule (a constant, so each program keeps one rule)
 *   VX_CL_RECORD_BYTES          its voxel_bytes
 *   VX_CL_PARAMS_BYTES          sizeof(vx_cl_params) on the host
 * The traversal is grid_traverse_core.h, the rays camera.h's camera_ray, the pixel samples strata.h,
 * the lights light.h's light_at, the random numbers rng.h, the shading the model's own code: what is
 * written here is only the tracer's control flow, which mirrors render.c line for line
 * (shadow_transmittance, gather_lights, evaluate, answer_for_voxel, trace_ray, render_row) so that both
 * backends give the same image.
 *
 * The shading cache works as the C tracer's: the first ray to visit a voxel computes its answer for
 * the direction voxel -> camera and publishes it (state 0 empty, 1 being written, 2 ready); a ray
 * that finds it ready reads it, one that does not computes it itself. The answer depends only on
 * the voxel, so whoever computes it writes the same numbers and the image does not depend on the
 * order in which work-items run. Publication: the entry is written, a global fence orders it before
 * state = 2, and readers use volatile loads (served from coherent memory, not a stale per-core
 * cache line on GPUs) of the state first, then of the entry. */
#define GT_ITER_INLINE static inline __attribute__((always_inline))
#include "camera.h"
#include "grid_traverse_core.h"
#include "light.h"
#include "model.h"
#include "render_params.h"
#include "rng.h"
#include "shading.h"
#include "strata.h"

/* A mismatch between the host's and this compiler's layout would read garbage: refuse to build. */
typedef char vx_cl_params_size_matches_host[sizeof(vx_cl_params) == VX_CL_PARAMS_BYTES ? 1 : -1];

/* What a work-item needs while tracing: the parameters, the grid (level tables in private memory,
 * pointing into the buffers), the records, the cache and its counters. */
typedef struct {
    __global const vx_cl_params *P;
    const voxel_grid *g;
    __global const uchar *records;
    volatile __global vx_cl_cache *cache;
    volatile __global int *state; /* per voxel: 0 empty, 1 being written, 2 ready */
    uint count[VX_CL_COUNTERS];
} cl_job;

static __global const void *cl_record(const cl_job *j, long index)
{
    return (__global const void *)(j->records + (size_t)index * VX_CL_RECORD_BYTES);
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
        light L = P->lights[li]; /* light_at takes a private pointer (OpenCL C 1.2: no generic one) */
        light_at(&L, c, &dir, &irr, &dist);
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

/* answer_for_voxel with the cache: the voxel's answer for the direction voxel -> camera. */
static void cl_answer_cached(cl_job *j, const grid_hit *h, vec3 dir, vx_answer *a)
{
    __global const vx_cl_params *P = j->P;
    volatile __global int *state = &j->state[h->index];
    volatile __global vx_cl_cache *ce = &j->cache[h->index];
    if (*state == 2) {
        a->radiance = v3(ce->radiance[0], ce->radiance[1], ce->radiance[2]);
        a->opacity = ce->opacity;
        for (int w = 0; w < VX_MASK_WORDS; w++)
            a->mask[w] = ce->mask[w];
        return;
    }
    vx_query q;
    vec3 centre;
    cl_query_for_voxel(j, h->x, h->y, h->z, &q, &centre);
    /* The cached direction: from the voxel's centre toward the camera. */
    vec3 to_cam = v3_sub(P->cam.position, centre);
    float dist = v3_length(to_cam);
    q.to_viewer = v3_normalize_or(to_cam, v3_scale(dir, -1.0f));
    q.ray_dir = v3_scale(q.to_viewer, -1.0f);
    q.ray_origin = P->cam.position;
    q.t0 = dist - 0.5f * j->g->voxel_size;
    q.t1 = dist + 0.5f * j->g->voxel_size;
    q.footprint = dist * P->spread;
    cl_evaluate(j, &q, h->index, centre, a);
    if (atomic_cmpxchg(state, 0, 1) == 0) {
        ce->radiance[0] = a->radiance.x;
        ce->radiance[1] = a->radiance.y;
        ce->radiance[2] = a->radiance.z;
        ce->opacity = a->opacity;
        for (int w = 0; w < VX_MASK_WORDS; w++)
            ce->mask[w] = a->mask[w];
        mem_fence(CLK_GLOBAL_MEM_FENCE);
        atomic_xchg(state, 2);
    }
}

static void cl_answer(cl_job *j, const grid_hit *h, vec3 org, vec3 dir, vx_answer *a)
{
    if (j->P->cache)
        cl_answer_cached(j, h, dir, a);
    else
        cl_answer_uncached(j, h, org, dir, a);
}

/* Adds a work-item's counters to its work-group's slot: VX_CL_COUNTERS 64-bit sums, each a low and
 * a high 32-bit word (a carry out of the low word's atomic add goes to the high word), so that
 * OpenCL 1.2's 32-bit atomics suffice. Work-items of one group rarely contend (a CPU device runs a
 * group on one thread), and the host reads back one slot per group, not per pixel. */
static void cl_flush_counts(__global uint *counts, const uint *c)
{
    __global uint *slot = counts + (size_t)get_group_id(0) * (2 * VX_CL_COUNTERS);
    for (int k = 0; k < VX_CL_COUNTERS; k++)
        if (c[k]) {
            uint old = atomic_add(&slot[2 * k], c[k]);
            if (old + c[k] < old)
                atomic_inc(&slot[2 * k + 1]);
        }
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

/* One pixel: render.c's render_row for one pixel (same random stream, strata, rays and box filter). */
static void cl_render_pixel(cl_job *j, __global float *image, int pix)
{
    __global const vx_cl_params *P = j->P;
    int width = P->width, spp = P->spp;
    int px = pix % width, py = pix / width;
    int dof = (P->effects & VX_EFFECT_DOF) != 0;
    camera cam = P->cam; /* camera_ray takes a private pointer */
    rng r = rng_seed(P->seed, (uint64_t)py * (uint64_t)width + (uint64_t)px);
    vec3 sum = v3(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < spp; i++) {
        float sx, sy, lu = 0, lv = 0;
        float r1 = rng_float(&r), r2 = rng_float(&r);
        truth_strata_sample(i, P->strata_x, P->strata_y, r1, r2, &sx, &sy);
        if (dof) {
            lu = rng_float(&r);
            lv = rng_float(&r);
        }
        vec3 org, dir;
        camera_ray(&cam, width, P->height, (float)px + sx, (float)py + sy, lu, lv, dof, &org, &dir);
        sum = v3_add(sum, cl_trace_ray(j, org, dir));
    }
    __global float *dst = &image[3 * (size_t)pix];
    dst[0] = sum.x / (float)spp;
    dst[1] = sum.y / (float)spp;
    dst[2] = sum.z / (float)spp;
}

/* Persistent work-items: each takes the next tile of VX_CL_TILE_PIXELS consecutive pixels from the
 * shared counter *next_tile until none is left, so the work goes to whoever is free, as the C
 * tracer's threads take rows (parallel_for). A fixed split of the pixels (one work-item per pixel,
 * the runtime handing each thread a share of the work-groups up front: PoCL gives each of 2 threads
 * half of them) leaves one core idle at the end whenever the halves cost unlike amounts, or another
 * process slows one core. The host launches one work-group per compute unit; on a CPU device a
 * group runs its work-items one after the other on one thread, so the first takes tiles until the
 * image is done and the rest find none. Which work-item renders a pixel changes nothing in it.
 * counts: one slot per work-group (cl_flush_counts). */
__kernel void vx_render(__global const vx_cl_params *P, __global ulong *cols, __global ulong *bits,
                        __global uint *prefix, __global const uchar *records, __global vx_cl_cache *cache,
                        __global int *state, __global float *image, __global uint *counts,
                        volatile __global int *next_tile, int pixels)
{
    voxel_grid g;
    vx_cl_grid_from_params(&g, &P->grid, cols, bits, prefix);
    cl_job j = {P, &g, records, cache, state, {0}};
    int tiles = (pixels + VX_CL_TILE_PIXELS - 1) / VX_CL_TILE_PIXELS;
    for (int tile = atomic_inc(next_tile); tile < tiles; tile = atomic_inc(next_tile)) {
        int end = min(pixels, (tile + 1) * VX_CL_TILE_PIXELS);
        for (int pix = tile * VX_CL_TILE_PIXELS; pix < end; pix++)
            cl_render_pixel(&j, image, pix);
    }
    cl_flush_counts(counts, j.count);
}
