/* Voxel marching on the C backend: render_voxel_core.h (the portable marcher, shared with the
 * OpenCL kernel) with the model's opacity and shade called through their function pointers, timed
 * for --stats, and the shading cache (shading_cache.h). */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "pixel_bounds.h"
#include "pixel_skip.h"
#include "prefault.h"
#include "render_internal.h"
#include "shading_cache.h"
#include "shadow_clip.h"
#include "shadow_memo.h"

/* The marcher's state: the shading cache (shading_cache.h) and the directional lights' opacity memo
 * (per voxel and light, SHADOW_MEMO_EMPTY until computed; written by whoever computes it first, always the
 * same bits). */
typedef struct {
    shading_cache cache;
    atomic_uint *memo;
    int lights;
    grid_distance skip; /* the primary rays' empty-space skip (pixel_skip.h); dist NULL: none */
    shadow_clip clips[VX_MAX_LIGHTS]; /* the shadow rays' ends per directional light (shadow_clip.h); g NULL: none */
    pixel_bounds bounds; /* the primary rays' depth bounds per pixel (pixel_bounds.h); near_t NULL: none */
    float *shadow_T;     /* the `voxel` shadow method's transmittance per voxel and light; NULL: none */
} voxel_state;

struct voxel_ctx;
static float call_opacity(struct voxel_ctx *x, const void *rec, const vx_query *q);
static void call_shade(struct voxel_ctx *x, const void *rec, const vx_query *q, vx_answer *a);
static int cache_get(struct voxel_ctx *x, int64_t index, vx_answer *a);
static void cache_put(struct voxel_ctx *x, int64_t index, const vx_answer *a);
#define VOXEL_OPACITY(x, rec, q) call_opacity(x, rec, q)
#define VOXEL_SHADE(x, rec, q, a) call_shade(x, rec, q, a)
#define VOXEL_COMPOSITING(x) ((x)->compositing)
#define VOXEL_CACHE_GET(x, index, a) cache_get(x, index, a)
#define VOXEL_CACHE_PUT(x, index, a) cache_put(x, index, a)
#define VOXEL_SHADOW_MEMO(x, index, light, q) memo_opacity(x, index, light, q)
#define VOXEL_HAS_TRANSMIT(x) ((x)->eval->transmit.fn != NULL)
#define VOXEL_TRANSMIT(x, rec, a, T) call_transmit(x, rec, a, T)
#define VOXEL_PIXEL_SKIP(x, org, dirs, n) pixel_skip_t((x)->skip, org, dirs, n)
#define VOXEL_SHADOW_END(x, light, o, dir, t_max) shadow_clip_end_lattice(&(x)->clips[light], o, dir, t_max)
#define VOXEL_SHADOW_DIRECTION(x, light, dir) voxel_light_direction(x, light, dir)
#define VOXEL_BOUNDS_ACTIVE(x) pixel_bounds_active((x)->bounds)
#define VOXEL_RAY_BOUNDS(x, px, py, dir, t_min, t_max) \
    pixel_bounds_ray_spans((x)->bounds, (x)->cam.forward, px, py, dir, t_min, t_max, &(x)->spans)
#define VOXEL_NEXT_SPAN(x, t_min, t_max) pixel_spans_next(&(x)->spans, t_min, t_max)
#define VOXEL_PIXEL_EMPTY(x, px, py) pixel_bounds_pixel_empty((x)->bounds, px, py)
#define VOXEL_PREFETCH_RECORD(x, index) voxel_prefetch_record(x, index)
#define VOXEL_SHADOW_PRECOMPUTED(x, index, light) \
    ((x)->shadow_T ? (x)->shadow_T[(size_t)(index) * (size_t)(x)->light_count + (size_t)(light)] : -1.0f)
#define VOXEL_SKIP_GROUP 16
/* Pixels of a row that share one skip (voxel_render_span): 4 pixels' 4 rays fill a group. Measured on
 * binary 256^3 (bunny, city, trees): 1 pixel 28.1 / 31.0 / 38.1 ms, 4 pixels 25.3 / 29.6 / 35.5,
 * 8 pixels (groups of 32) no better than 4. */
#define VOXEL_SKIP_PIXELS 4
/* The DDA's walk inlined into the ray loops, as the OpenCL kernel has it: its state then stays in
 * registers between two cells instead of going through the iterator in memory at every voxel met
 * (alpha 75 -> 67 ms, binary 31 -> 28 ms on bunny 256^3; the same cells, so the same images). */
#define GT_ITER_INLINE static inline __attribute__((always_inline))
#define VOXEL_CTX_BACKEND_FIELDS \
    const vx_voxel_eval *eval;   \
    int compositing;             \
    shading_cache shading;       \
    atomic_uint *memo;           \
    int memo_lights;             \
    const grid_distance *skip;   \
    const shadow_clip *clips;    \
    const pixel_bounds *bounds;  \
    pixel_spans spans; /* the primary ray's spans after the one being walked (VOXEL_NEXT_SPAN) */ \
    const float *shadow_T;       \
    gt_direction light_dir[VX_MAX_LIGHTS]; /* each directional light's, prepared (voxel_prepare_light_directions) */ \
    uint64_t model_cycles;       \
    int timed; /* the model's calls are timed in this row (render_internal.h) */
static float memo_opacity(struct voxel_ctx *x, int64_t index, int light, const vx_query *q);
static float call_transmit(struct voxel_ctx *x, const void *rec, float a, float T);
static void voxel_prefetch_record(const struct voxel_ctx *x, int64_t index);
#include "grid_traverse_core.h" /* gt_direction, for the declaration below (after GT_ITER_INLINE) */
static const gt_direction *voxel_light_direction(const struct voxel_ctx *x, int li, vec3 dir);
#include "render_voxel_core.h"

/* The shadow rays' prepared direction toward light li when dir is that directional light's
 * (voxel_prepare_light_directions), else NULL. */
static const gt_direction *voxel_light_direction(const voxel_ctx *x, int li, vec3 dir)
{
    const light *L = &x->lights[li];
    if (L->type != LIGHT_DIRECTIONAL || dir.x != L->direction.x || dir.y != L->direction.y || dir.z != L->direction.z)
        return NULL;
    return &x->light_dir[li];
}

/* Every directional light's direction, prepared for the shadow rays' walks. */
static void voxel_prepare_light_directions(voxel_ctx *x)
{
    for (int li = 0; li < x->light_count && li < VX_MAX_LIGHTS; li++)
        gt_direction_prepare(x->g, 0, x->lights[li].direction, &x->light_dir[li]);
}

/* Every cache line of voxel `index`'s record (records are packed, so one may straddle a line more
 * than its size suggests: the last byte's line too). */
static void voxel_prefetch_record(const voxel_ctx *x, int64_t index)
{
    const unsigned char *r = voxel_record(x, index);
    for (size_t o = 0; o < x->record_bytes; o += 64)
        __builtin_prefetch(r + o);
    __builtin_prefetch(r + x->record_bytes - 1);
}

static float call_opacity(voxel_ctx *x, const void *rec, const vx_query *q)
{
    float a;
    MODEL_CALL(x, a = x->eval->opacity.fn(rec, q));
    return a;
}

static float call_transmit(voxel_ctx *x, const void *rec, float a, float T)
{
    float t;
    MODEL_CALL(x, t = x->eval->transmit.fn(rec, a, T));
    return t;
}

static void call_shade(voxel_ctx *x, const void *rec, const vx_query *q, vx_answer *a)
{
    MODEL_CALL(x, x->eval->shade.fn(rec, q, a));
}

static float memo_opacity(voxel_ctx *x, int64_t index, int light, const vx_query *q)
{
    atomic_uint *slot = &x->memo[(size_t)index * (size_t)x->memo_lights + (size_t)light];
    unsigned bits = atomic_load_explicit(slot, memory_order_relaxed);
    float a;
    if (bits != SHADOW_MEMO_EMPTY) {
        x->counts.memo_hits++;
        memcpy(&a, &bits, sizeof a);
        return a;
    }
    a = call_opacity(x, voxel_record(x, index), q);
    memcpy(&bits, &a, sizeof bits);
    atomic_store_explicit(slot, bits, memory_order_relaxed);
    return a;
}

static int cache_get(voxel_ctx *x, int64_t index, vx_answer *a)
{
    return shading_cache_get(&x->shading, index, &a->radiance, &a->opacity);
}

static void cache_put(voxel_ctx *x, int64_t index, const vx_answer *a)
{
    shading_cache_put(&x->shading, index, a->radiance, a->opacity);
}

static int voxel_precompute(render_job *j, voxel_state *st, vx_err *e);

/* What shadow rays march through: the directional lights' opacity memo and the rays' ends (only
 * marched shadows cast shadow rays). */
static int voxel_prepare_shadow_rays(render_job *j, voxel_state *st, vx_err *e)
{
    const scene *s = j->s;
    size_t n = grid_count(j->g, 0);
    st->lights = render_shadow_memo_lights(s, j->m, j->shadows);
    if (st->lights) {
        size_t slots = (n ? n : 1) * (size_t)st->lights;
        /* Filled byte by byte: the empty slot's bits must be one byte repeated. */
        _Static_assert(SHADOW_MEMO_EMPTY == (SHADOW_MEMO_EMPTY & 0xFFu) * 0x01010101u,
                       "SHADOW_MEMO_EMPTY is not one byte repeated");
        st->memo = vx_alloc_touched(slots * sizeof *st->memo, (int)(SHADOW_MEMO_EMPTY & 0xFFu));
        if (!st->memo)
            return vx_fail(e, "out of memory for the shadow opacity memo (%zu voxels)", n);
        j->cache_bytes += slots * sizeof *st->memo;
    }
    if (j->o->shadow_clip && (s->effects & EFFECT_SHADOWS) && !j->shadows)
        for (int li = 0; li < s->light_count && li < VX_MAX_LIGHTS; li++) {
            if (s->lights[li].type != LIGHT_DIRECTIONAL)
                continue;
            if (shadow_clip_build(&st->clips[li], j->g, s->lights[li].direction))
                return vx_fail(e, "out of memory for the shadow rays' ends (light %d)", li + 1);
            j->map_bytes += shadow_clip_bytes(&st->clips[li]);
        }
    return 0;
}

/* Allocated and touched here, before the threads start and outside the render's clock: pages first
 * written by the render threads cost a zero-page fault and a TLB shootdown of the other core each
 * (issue 15: binary gained almost nothing from a second thread). vx_alloc_touched (prefault.h), not
 * malloc + memset: GCC turns that pair into a calloc, whose pages stay untouched. */
static int voxel_prepare(render_job *j, vx_err *e)
{
    const scene *s = j->s;
    size_t n = grid_count(j->g, 0);
    voxel_state *st = calloc(1, sizeof *st);
    if (!st)
        return vx_fail(e, "out of memory for the render");
    j->state = st;
    if (j->o->cache) {
        shading_cache_size(n, (size_t)j->o->width * (size_t)j->o->height, j->o->cache_slots, &st->cache.count,
                           &st->cache.hash_bits);
        st->cache.slots = vx_alloc_touched(st->cache.count * sizeof(shading_cache_slot), 0); /* tag 0: empty */
        if (!st->cache.slots)
            return vx_fail(e, "out of memory for the shading cache (%zu slots)", st->cache.count);
        j->cache_bytes += st->cache.count * sizeof(shading_cache_slot);
    }
    if (voxel_prepare_shadow_rays(j, st, e))
        return -1;
    /* The skip serves only the frames without the pixels' depth bounds: under depth of field, or when
     * a voxel may straddle the camera's plane (the camera inside the grid). Elsewhere its build
     * (6.5 ms on bunny 256^3, where alpha's frame takes 45) would be work for nothing. */
    int bounds = j->o->pixel_bounds && !(s->effects & EFFECT_DOF);
    /* The depth slabs serve the walks that go on past a voxel: a first-hit model's ray ends at its
     * first voxel that is not transparent, and with the slabs about 1 % of binary's rays walked a
     * second span (bunny 256^3: 149,499 walks for 148,224 rays), so building them was work for
     * nothing (3 % of binary's instructions a frame). */
    int slabs = j->m->voxel->compositing != VX_COMPOSITE_FIRST_HIT;
    if (bounds && (pixel_bounds_alloc(&st->bounds, j->o->width, j->o->height, VOXEL_BOUNDS_TILE_SHIFT,
                                      parallel_threads(j->o->threads)) ||
                   (slabs && pixel_bounds_alloc_slabs(&st->bounds))))
        return vx_fail(e, "out of memory for the pixels' depth bounds");
    j->map_bytes += pixel_bounds_bytes(&st->bounds);
    if (j->o->empty_skip && (!bounds || pixel_bounds_may_fail(&st->bounds, j->g, &s->camera)) &&
        grid_distance_build(&st->skip, j->g))
        return vx_fail(e, "out of memory for the empty-space skip's distance field");
    /* Last: the precomputation marches through the memo and the shadow rays' ends made above. */
    if (j->shadow_method == SHADOW_VOXEL && voxel_precompute(j, st, e))
        return -1;
    return 0;
}

/* A march's context for job j (one per row, or per share of the shadows' precomputation). */
static void voxel_ctx_init(const render_job *j, voxel_ctx *x, int timed)
{
    const render_options *o = j->o;
    const scene *s = j->s;
    memset(x, 0, sizeof *x);
    x->timed = timed;
    x->g = j->g;
    x->records = j->records;
    x->record_bytes = j->m->record.bytes;
    x->cam = s->camera;
    x->background = s->background;
    x->light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    for (int li = 0; li < x->light_count; li++)
        x->lights[li] = s->lights[li];
    x->effects = s->effects;
    x->spread = j->spread;
    x->stop_opacity = o->stop_opacity;
    x->shadow_skip = o->shadow_skip;
    x->cache = o->cache;
    voxel_set_camera_cell(x);
    voxel_prepare_light_directions(x);
    const voxel_state *st = j->state;
    x->eval = j->m->voxel;
    x->compositing = j->m->voxel->compositing;
    x->shading = st->cache;
    x->memo = st->memo;
    x->memo_lights = st->lights;
    x->opacity_by_direction = st->memo != NULL;
    x->view_tile = view_tile_width(render_view_tile_pixels(j->m, o), j->spread);
    x->skip = &st->skip;
    x->clips = st->clips;
    x->bounds = &st->bounds;
    x->shadow_T = st->shadow_T;
    shadow_set_view(j->shadows, &x->shadows);
}

/* The `voxel` shadow method's precomputation: every voxel's transmittance toward every light
 * (render_voxel_core.h's voxel_precompute_shadows), SHADOW_PRECOMPUTE_SHARES shares of the voxels
 * taken by the threads in turn; each voxel's numbers depend on it alone, so they do not depend on
 * the thread count. */
#define SHADOW_PRECOMPUTE_SHARES 256

typedef struct {
    const render_job *j;
    float *T;
    size_t voxels;
} shadow_precompute_job;

static void shadow_precompute_share(void *p, int64_t share, int thread)
{
    const shadow_precompute_job *J = p;
    (void)thread;
    voxel_ctx x;
    voxel_ctx_init(J->j, &x, 0);
    x.shadow_T = NULL; /* marched, not read back */
    size_t lo = J->voxels * (size_t)share / SHADOW_PRECOMPUTE_SHARES;
    size_t hi = J->voxels * (size_t)(share + 1) / SHADOW_PRECOMPUTE_SHARES;
    for (size_t i = lo; i < hi; i++) {
        grid_hit h = {0};
        grid_coords(x.g, 0, i, &h.x, &h.y, &h.z);
        h.index = (int64_t)i;
        voxel_precompute_shadows(&x, &h, &J->T[i * (size_t)x.light_count]);
    }
}

static int voxel_precompute(render_job *j, voxel_state *st, vx_err *e)
{
    size_t voxels = grid_count(j->g, 0);
    int lights = j->s->light_count < VX_MAX_LIGHTS ? j->s->light_count : VX_MAX_LIGHTS;
    size_t bytes = (voxels ? voxels : 1) * (size_t)lights * sizeof *st->shadow_T;
    /* Every core when the options say 0 (render_options.threads), as the frame: parallel_for takes
     * its count as given, and 0 ran the precomputation on one thread (bunny 256^3, alpha: 24.0 ms
     * against 12.5 with --threads 2). */
    int threads = parallel_threads(j->o->threads);
    parallel_prestart(threads); /* before the clock (parallel.h) */
    double t0 = now_seconds();
    float *T = vx_alloc_touched(bytes, 0);
    if (!T)
        return vx_fail(e, "out of memory for the voxels' precomputed shadows (%zu voxels, %d lights)", voxels, lights);
    shadow_precompute_job J = {j, T, voxels};
    parallel_for(SHADOW_PRECOMPUTE_SHARES, threads, shadow_precompute_share, &J,
                 j->o->progress ? "shadows" : NULL);
    st->shadow_T = T;
    j->shadow_build_seconds = now_seconds() - t0;
    j->shadow_bytes = bytes;
    return 0;
}

static void voxel_row(void *p, int64_t row, int thread)
{
    render_job *j = p;
    const render_options *o = j->o;
    int timed = render_row_timed(row);
    uint64_t c0 = timed ? cycles() : 0;
    voxel_ctx x;
    voxel_ctx_init(j, &x, timed);
    int sx, sy;
    truth_strata(o->spp, &sx, &sy);
    int py = (int)row;
    for (int px = 0; px < o->width; px += VOXEL_SKIP_PIXELS) {
        int count = o->width - px < VOXEL_SKIP_PIXELS ? o->width - px : VOXEL_SKIP_PIXELS;
        voxel_render_span(&x, o->seed, px, count, py, o->width, o->height, o->spp, sx, sy,
                          &j->out->data[3 * ((size_t)py * (size_t)o->width + (size_t)px)]);
    }
    thread_counts *tc = &j->tc[thread];
    tc->rays += x.counts.rays;
    tc->shadow_rays += x.counts.shadow_rays;
    tc->voxel_visits += x.counts.visits;
    tc->model_evals += x.counts.evals;
    tc->cache_hits += x.counts.cache_hits;
    tc->memo_hits += x.counts.memo_hits;
    tc->shadow_queries += x.shadows.queries;
    tc->model_cycles += x.model_cycles;
    if (timed)
        tc->total_cycles += cycles() - c0;
}

static void voxel_release(render_job *j)
{
    voxel_state *st = j->state;
    if (st) {
        free(st->cache.slots);
        free(st->memo);
        free(st->shadow_T);
        grid_distance_free(&st->skip);
        pixel_bounds_free(&st->bounds);
        for (int li = 0; li < VX_MAX_LIGHTS; li++)
            shadow_clip_free(&st->clips[li]);
        free(st);
    }
    j->state = NULL;
}

/* The frame's own set-up, inside its clock: the pixels' depth bounds (they depend on the camera). */
static void voxel_begin(render_job *j, int threads)
{
    voxel_state *st = j->state;
    pixel_bounds_build(&st->bounds, j->g, &j->s->camera, threads);
}

const render_marcher render_voxel_marcher = {voxel_prepare, voxel_begin, voxel_row, voxel_release};

int render_shadow_memo_lights(const scene *s, const vx_model *m, const shadow_set *maps)
{
    int directional = 0, lights = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    for (int li = 0; li < lights; li++)
        directional |= s->lights[li].type == LIGHT_DIRECTIONAL;
    return (s->effects & EFFECT_SHADOWS) && directional && m->voxel->opacity_by_direction && !maps ? lights : 0;
}

int render_view_tile_pixels(const vx_model *m, const render_options *o)
{
    return m->voxel && o->cache && o->view_tiles ? m->voxel->view_tile_pixels : 0;
}

int render_voxel_shadows(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                         const render_options *o, float **T, size_t *bytes, double *seconds, vx_err *e)
{
    *T = NULL;
    *bytes = 0;
    *seconds = 0.0;
    if (!m->voxel) /* callers refuse a cone model first (render_shadow_method_refused) */
        return vx_fail(e, "render_voxel_shadows: %s has no per-voxel evaluation", m->name);
    render_job j = {s, g, m, records, o, NULL, NULL, camera_pixel_spread(&s->camera, o->height), NULL, NULL,
                    0, 0, SHADOW_VOXEL, 0.0, 0};
    voxel_state *st = calloc(1, sizeof *st);
    if (!st)
        return vx_fail(e, "out of memory for the voxels' precomputed shadows");
    j.state = st;
    int rc = voxel_prepare_shadow_rays(&j, st, e) || voxel_precompute(&j, st, e) ? -1 : 0;
    if (!rc) {
        *T = st->shadow_T;
        *bytes = j.shadow_bytes;
        *seconds = j.shadow_build_seconds;
        st->shadow_T = NULL;
    }
    voxel_release(&j);
    return rc;
}
