/* Voxel marching on the C backend: render_voxel_core.h (the portable marcher, shared with the
 * OpenCL kernel) with the model's opacity and shade called through their function pointers, timed
 * for --stats, and the shading cache as C11 atomics. */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "render_internal.h"

/* A voxel's cached answer for the direction voxel -> camera. state: 0 empty, 1 being computed,
 * 2 ready. The value depends only on the voxel, so whichever thread computes it writes the same
 * numbers: the image stays independent of the thread count. */
typedef struct {
    vec3 radiance;
    float opacity;
    atomic_int state;
} cache_entry;

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
#define VOXEL_CTX_BACKEND_FIELDS \
    const vx_voxel_eval *eval;   \
    int compositing;             \
    cache_entry *entries;        \
    uint64_t model_cycles;
#include "render_voxel_core.h"

static float call_opacity(voxel_ctx *x, const void *rec, const vx_query *q)
{
    uint64_t c0 = cycles();
    float a = x->eval->opacity.fn(rec, q);
    x->model_cycles += cycles() - c0;
    return a;
}

static void call_shade(voxel_ctx *x, const void *rec, const vx_query *q, vx_answer *a)
{
    uint64_t c0 = cycles();
    x->eval->shade.fn(rec, q, a);
    x->model_cycles += cycles() - c0;
}

static int cache_get(voxel_ctx *x, int64_t index, vx_answer *a)
{
    cache_entry *ce = &x->entries[index];
    if (atomic_load_explicit(&ce->state, memory_order_acquire) != 2)
        return 0;
    a->radiance = ce->radiance;
    a->opacity = ce->opacity;
    return 1;
}

static void cache_put(voxel_ctx *x, int64_t index, const vx_answer *a)
{
    cache_entry *ce = &x->entries[index];
    int expected = 0;
    if (atomic_compare_exchange_strong(&ce->state, &expected, 1)) {
        ce->radiance = a->radiance;
        ce->opacity = a->opacity;
        atomic_store_explicit(&ce->state, 2, memory_order_release);
    }
}

static int voxel_prepare(render_job *j, vx_err *e)
{
    j->state = NULL;
    if (!j->o->cache)
        return 0;
    size_t n = grid_count(j->g, 0);
    j->state = calloc(n ? n : 1, sizeof(cache_entry));
    return j->state ? 0 : vx_fail(e, "out of memory for the shading cache (%zu voxels)", n);
}

static void voxel_row(void *p, int64_t row, int thread)
{
    render_job *j = p;
    const render_options *o = j->o;
    const scene *s = j->s;
    uint64_t c0 = cycles();
    voxel_ctx x;
    memset(&x, 0, sizeof x);
    x.g = j->g;
    x.records = j->records;
    x.record_bytes = j->m->record.bytes;
    x.cam = s->camera;
    x.background = s->background;
    x.light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    for (int li = 0; li < x.light_count; li++)
        x.lights[li] = s->lights[li];
    x.effects = s->effects;
    x.spread = j->spread;
    x.stop_opacity = o->stop_opacity;
    x.shadow_skip = o->shadow_skip;
    x.cache = o->cache;
    x.eval = j->m->voxel;
    x.compositing = j->m->voxel->compositing;
    x.entries = j->state;
    int sx, sy;
    truth_strata(o->spp, &sx, &sy);
    int py = (int)row;
    for (int px = 0; px < o->width; px++)
        voxel_render_pixel(&x, o->seed, px, py, o->width, o->height, o->spp, sx, sy,
                           &j->out->data[3 * ((size_t)py * (size_t)o->width + (size_t)px)]);
    thread_counts *tc = &j->tc[thread];
    tc->rays += x.counts.rays;
    tc->shadow_rays += x.counts.shadow_rays;
    tc->voxel_visits += x.counts.visits;
    tc->model_evals += x.counts.evals;
    tc->cache_hits += x.counts.cache_hits;
    tc->model_cycles += x.model_cycles;
    tc->total_cycles += cycles() - c0;
}

static void voxel_release(render_job *j)
{
    free(j->state);
    j->state = NULL;
}

const render_marcher render_voxel_marcher = {voxel_prepare, voxel_row, voxel_release};
