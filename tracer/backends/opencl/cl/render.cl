/* The OpenCL voxel tracer: a thin driver of render_voxel_core.h, the marcher the C backend runs
 * (tracer/render/render_voxel.c). opencl_program.c assembles the program: prelude.h, the model's
 * portable source, then this file, with
 *   VX_CL_OPACITY, VX_CL_SHADE  the model's opacity and shade functions (by name)
 *   VX_CL_TRANSMIT              its transmit function, when it declares one
 *   VX_CL_COMPOSITING           its VX_COMPOSITE_* rule (a constant, so each program keeps one rule)
 *   VX_CL_RECORD_BYTES          its record.bytes
 *   VX_CL_PARAMS_BYTES          sizeof(vx_cl_params) on the host
 * What is written here is only what differs between the backends: the parameters' block, the
 * shading cache's memory and publication, the counters, and which pixels a work-item takes.
 *
 * The cache's publication: the entry is written, a global fence orders it before state = 2, and
 * readers use volatile loads (served from coherent memory, not a stale per-core cache line on GPUs)
 * of the state first, then of the entry. */
#define GT_ITER_INLINE static inline __attribute__((always_inline))
#include "flush_counts.h"
#include "render_params.h"
#include "shadow_memo.h"

/* A mismatch between the host's and this compiler's layout would read garbage: refuse to build. */
typedef char vx_cl_params_size_matches_host[sizeof(vx_cl_params) == VX_CL_PARAMS_BYTES ? 1 : -1];

struct voxel_ctx;
static int cl_cache_get(struct voxel_ctx *x, long index, vx_answer *a);
static void cl_cache_put(struct voxel_ctx *x, long index, const vx_answer *a);
#define VOXEL_OPACITY(x, rec, q) VX_CL_OPACITY(rec, q)
#define VOXEL_SHADE(x, rec, q, a) VX_CL_SHADE(rec, q, a)
#define VOXEL_COMPOSITING(x) VX_CL_COMPOSITING
#ifdef VX_CL_TRANSMIT
#define VOXEL_HAS_TRANSMIT(x) 1
#define VOXEL_TRANSMIT(x, rec, a, T) VX_CL_TRANSMIT(rec, a, T)
#endif
#define VOXEL_CACHE_GET(x, index, a) cl_cache_get(x, index, a)
#define VOXEL_CACHE_PUT(x, index, a) cl_cache_put(x, index, a)
static float cl_memo_opacity(struct voxel_ctx *x, long index, int light, const vx_query *q);
#define VOXEL_SHADOW_MEMO(x, index, light, q) cl_memo_opacity(x, index, light, q)
/* The `voxel` shadow method's transmittances, precomputed by the host (render_voxel_shadows). */
#define VOXEL_SHADOW_PRECOMPUTED(x, index, light) \
    ((x)->shadow_T_lights ? (x)->shadow_T[(index) * (long)(x)->shadow_T_lights + (light)] : -1.0f)
#define VOXEL_CTX_BACKEND_FIELDS                 \
    volatile __global vx_cl_cache *cache_entries; \
    volatile __global int *cache_state; /* per voxel: 0 empty, 1 being written, 2 ready */ \
    __global uint *memo;                /* per voxel and light: an opacity's bits, or SHADOW_MEMO_EMPTY */ \
    int memo_lights; \
    __global const float *shadow_T;     /* per voxel and light: the voxel method's transmittance */ \
    int shadow_T_lights;                /* its slots per voxel; 0: none */
#include "render_voxel_core.h"

/* The directional lights' opacity memo, as the C backend's (render_voxel.c's memo_opacity): a
 * voxel's opacity toward a directional light is asked of the model once and then read back. Shadow
 * rays cross the same voxels toward the same light again and again: without the memo every step
 * re-evaluated the model (vmesh: its view and 16 window cells each time). Whoever writes a slot
 * writes the same bits (a pure function of the record and the light's direction) in one aligned
 * 32-bit store, so two work-items racing on it change nothing, and a stale read (a GPU
 * multiprocessor's cached SHADOW_MEMO_EMPTY) only costs a recomputation. Plain loads, not volatile ones as
 * the shading cache's (whose entry is four words published by a flag): measured on an H200 (bunny,
 * city 256^3), volatile slots took vmesh 29.0 / 59.6 ms a frame and vicini 6.2 / 8.1 ms, plain ones
 * 16.7 / 29.8 and 4.3 / 4.8 ms (vicini's 4.2 / 4.7 before the memo). */
static float cl_memo_opacity(voxel_ctx *x, long index, int light, const vx_query *q)
{
    __global uint *slot = &x->memo[index * (long)x->memo_lights + light];
    uint bits = *slot;
    if (bits != SHADOW_MEMO_EMPTY) {
        x->counts.memo_hits++;
        return as_float(bits);
    }
    float a = VOXEL_OPACITY(x, voxel_record(x, index), q);
    *slot = as_uint(a);
    return a;
}

static int cl_cache_get(voxel_ctx *x, long index, vx_answer *a)
{
    if (x->cache_state[index] != 2)
        return 0;
    volatile __global vx_cl_cache *ce = &x->cache_entries[index];
    a->radiance = v3(ce->radiance[0], ce->radiance[1], ce->radiance[2]);
    a->opacity = ce->opacity;
    return 1;
}

static void cl_cache_put(voxel_ctx *x, long index, const vx_answer *a)
{
    volatile __global int *state = &x->cache_state[index];
    volatile __global vx_cl_cache *ce = &x->cache_entries[index];
    if (atomic_cmpxchg(state, 0, 1) == 0) {
        ce->radiance[0] = a->radiance.x;
        ce->radiance[1] = a->radiance.y;
        ce->radiance[2] = a->radiance.z;
        ce->opacity = a->opacity;
        mem_fence(CLK_GLOBAL_MEM_FENCE);
        atomic_xchg(state, 2);
    }
}

/* Persistent work-items: each takes the next tile of VX_CL_TILE_PIXELS consecutive pixels from the
 * shared counter *next_tile until none is left, so the work goes to whoever is free, as the C
 * tracer's threads take rows (parallel_for). A fixed split of the pixels (one work-item per pixel,
 * the runtime handing each thread a share of the work-groups up front: PoCL gives each of 2 threads
 * half of them) leaves one core idle at the end whenever the halves cost unlike amounts, or another
 * process slows one core. The host launches one work-group per compute unit; on a CPU device a
 * group runs its work-items one after the other on one thread, so the first takes tiles until the
 * image is done and the rest find none. On a GPU (VX_CL_WIDE) the host launches 16 groups per
 * compute unit and each work-item takes one pixel at a time. Which work-item renders a pixel
 * changes nothing in it. counts: one slot per work-group (flush_counts.h). */
__kernel void vx_render(__global const vx_cl_params *P, __global ulong *cols, __global ulong *bits,
                        __global uint *prefix, __global const uchar *records, __global vx_cl_cache *cache,
                        __global int *state, __global uint *memo, __global const uchar *shadow_block,
                        __global const float *shadow_T, __global float *image,
                        __global uint *counts,
                        volatile __global int *next_tile, int pixels)
{
    voxel_grid g;
    vx_cl_grid_from_params(&g, &P->grid, cols, bits, prefix);
    voxel_ctx x = {0};
    x.g = &g;
    x.records = records;
    x.record_bytes = VX_CL_RECORD_BYTES;
    x.cam = P->cam;
    x.background = P->background;
    x.light_count = P->light_count < VX_MAX_LIGHTS ? P->light_count : VX_MAX_LIGHTS;
    for (int li = 0; li < x.light_count; li++)
        x.lights[li] = P->lights[li];
    x.effects = P->effects;
    x.spread = P->spread;
    x.stop_opacity = P->stop_opacity;
    x.shadow_skip = P->shadow_skip;
    x.cache = P->cache;
    voxel_set_camera_cell(&x);
    x.cache_entries = cache;
    x.cache_state = state;
    x.memo = memo;
    x.memo_lights = P->memo_lights;
    x.opacity_by_direction = P->memo_lights > 0;
    x.view_tile = P->view_tile;
    x.shadow_T = shadow_T;
    x.shadow_T_lights = P->shadow_T_lights;
    vx_cl_shadow_maps(&x.shadows, &P->shadows, shadow_block);
    int tiles = (pixels + VX_CL_TILE_PIXELS - 1) / VX_CL_TILE_PIXELS;
    for (int tile = atomic_inc(next_tile); tile < tiles; tile = atomic_inc(next_tile)) {
        int end = min(pixels, (tile + 1) * VX_CL_TILE_PIXELS);
        for (int pix = tile * VX_CL_TILE_PIXELS; pix < end; pix++)
            voxel_render_pixel(&x, P->seed, pix % P->width, pix / P->width, P->width, P->height, P->spp, P->strata_x,
                               P->strata_y, &image[3 * (size_t)pix]);
    }
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_RAYS, x.counts.rays);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_SHADOW_RAYS, x.counts.shadow_rays);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_VISITS, x.counts.visits);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_EVALS, x.counts.evals);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_CACHE_HITS, x.counts.cache_hits);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_MEMO_HITS, x.counts.memo_hits);
    vx_cl_flush_count(counts, VX_CL_COUNTERS, VX_CL_SHADOW_QUERIES, x.shadows.queries);
}
