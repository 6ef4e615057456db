/* Which shadow method a render uses, and its precomputed maps served from this process's cache,
 * keyed by everything that decides them: the method and resolution, the scene (its identity, the
 * materials' σ, its bounds), every light, and for slicemap-model the model and its records. A
 * light moved, another resolution or another bake is another key: the maps are built again. The
 * cache keeps at most CACHE_ENTRIES sets (the Python API renders many frames of one scene in one
 * process; the command line builds once per run); a set in use is never evicted. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "shadow_build_internal.h"
#include "shadow_set.h"

#define CACHE_ENTRIES 8

static const char *const names[] = {"march", "slicemap", "slicemap-model", "voxel"};
#define METHODS ((int)(sizeof names / sizeof *names))

int shadow_method_from_name(const char *name)
{
    for (int i = 0; i < METHODS; i++)
        if (strcmp(name, names[i]) == 0)
            return i;
    return -1;
}

const char *shadow_method_name(int method)
{
    return method >= 0 && method < METHODS ? names[method] : "none";
}

int shadow_effective_method(const scene *s, const shadow_request *r)
{
    if (!(s->effects & EFFECT_SHADOWS) || s->light_count == 0)
        return -1;
    return r && r->method >= 0 ? r->method : s->shadow_method;
}

/* The methods that build maps around the scene's bounds, which move with an animation's frames. */
static int builds_maps(const scene *s, const shadow_request *r)
{
    int method = shadow_effective_method(s, r);
    return method == SHADOW_SLICEMAP || method == SHADOW_SLICEMAP_MODEL;
}

int shadow_lights_depend_on_pose(const scene *s, const shadow_request *r)
{
    for (int li = 0; builds_maps(s, r) && li < s->light_count && li < VX_MAX_LIGHTS; li++)
        if (s->lights[li].type == LIGHT_POINT)
            return 1;
    return 0;
}

int shadow_check_lights(const scene *s, const shadow_request *r, vx_err *e)
{
    for (int li = 0; builds_maps(s, r) && li < s->light_count && li < VX_MAX_LIGHTS; li++)
        if (s->lights[li].type == LIGHT_POINT && shadow_point_light_refused(s, &s->lights[li], li, e))
            return -1;
    return 0;
}

typedef struct {
    shadow_set *set;
    int users;
    uint64_t age;
} cache_entry;

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static cache_entry cache[CACHE_ENTRIES];
static uint64_t clock_ticks;

static uint64_t mix(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = p;
    size_t i = 0;
    for (; i + 8 <= n; i += 8) { /* 8 bytes at a time: records of large bakes are hashed too */
        uint64_t w;
        memcpy(&w, b + i, 8);
        h = (h ^ w) * 0x100000001b3ULL;
        h ^= h >> 29;
    }
    for (; i < n; i++)
        h = (h ^ b[i]) * 0x100000001b3ULL;
    return h;
}

static uint64_t key_of(const scene *s, const voxel_grid *g, const vx_model *m, const void *records, int method,
                       int res)
{
    uint64_t h = 0xcbf29ce484222325ULL;
    h = mix(h, &method, sizeof method);
    h = mix(h, &res, sizeof res);
    h = mix(h, &s->identity, sizeof s->identity);
    h = mix(h, &s->bounds_lo, sizeof s->bounds_lo);
    h = mix(h, &s->bounds_hi, sizeof s->bounds_hi);
    h = mix(h, s->shadow_sigma, (size_t)s->material_count * sizeof *s->shadow_sigma);
    h = mix(h, s->lights, (size_t)s->light_count * sizeof *s->lights);
    if (method == SHADOW_SLICEMAP_MODEL) {
        h = mix(h, m->name, strlen(m->name));
        h = mix(h, &g->n, sizeof g->n);
        h = mix(h, g->origin_d, sizeof g->origin_d);
        h = mix(h, &g->voxel_size_d, sizeof g->voxel_size_d);
        size_t count = 0;
        for (int l = 0; l < (m->record.levels ? g->levels : 1); l++)
            count += grid_count(g, l);
        h = mix(h, records, count * m->record.bytes);
    }
    return h;
}

int shadow_prepare(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                   const shadow_request *r, const shadow_set **out, shadow_stats *st, vx_err *e)
{
    *out = NULL;
    memset(st, 0, sizeof *st);
    int method = shadow_effective_method(s, r);
    st->method = method;
    if (method <= SHADOW_MARCH || method == SHADOW_VOXEL) /* no maps (the voxel marcher precomputes its own) */
        return 0;
    if (method == SHADOW_SLICEMAP_MODEL && (!m || !g || !records || !r || !r->fill_model))
        return vx_fail(e, "--shadows slicemap-model: needs a model's bake (the ground truth has none: use march or "
                          "slicemap)");
    int res = r && r->res > 0 ? r->res : s->shadow_res > 0 ? s->shadow_res
                                       : method == SHADOW_SLICEMAP_MODEL ? (3 * g->n + 1) / 2
                                                                        : SHADOW_DEFAULT_RES;
    if (res > SHADOW_MAX_RES)
        return vx_fail(e, "--shadow-res %d: at most %d columns per side", res, SHADOW_MAX_RES);
    st->res = res;
    uint64_t key = key_of(s, g, m, records, method, res);
    pthread_mutex_lock(&lock);
    for (int i = 0; i < CACHE_ENTRIES; i++)
        if (cache[i].set && cache[i].set->key == key) {
            cache[i].users++;
            cache[i].age = ++clock_ticks;
            *out = cache[i].set;
            st->bytes = cache[i].set->bytes;
            st->cache_hit = 1;
            pthread_mutex_unlock(&lock);
            return 0;
        }
    pthread_mutex_unlock(&lock);
    shadow_set *set = malloc(sizeof *set);
    if (!set)
        return vx_fail(e, "out of memory for the shadow maps");
    if (shadow_set_build(s, g, m, records, method, res, r ? r->threads : 0, r ? r->fill_model : NULL, set, e)) {
        free(set);
        return -1;
    }
    set->key = key;
    st->build_seconds = set->build_seconds;
    st->bytes = set->bytes;
    *out = set;
    /* Into the cache: a free slot, else the oldest set nobody uses; none: the caller's alone. */
    pthread_mutex_lock(&lock);
    int slot = -1;
    for (int i = 0; slot < 0 && i < CACHE_ENTRIES; i++)
        if (!cache[i].set)
            slot = i;
    if (slot < 0)
        for (int i = 0; i < CACHE_ENTRIES; i++)
            if (!cache[i].users && (slot < 0 || cache[i].age < cache[slot].age))
                slot = i;
    if (slot >= 0) {
        if (cache[slot].set) {
            shadow_set_free(cache[slot].set);
            free(cache[slot].set);
        }
        cache[slot].set = set;
        cache[slot].users = 1;
        cache[slot].age = ++clock_ticks;
    }
    pthread_mutex_unlock(&lock);
    return 0;
}

void shadow_release(const shadow_set *set)
{
    if (!set)
        return;
    pthread_mutex_lock(&lock);
    for (int i = 0; i < CACHE_ENTRIES; i++)
        if (cache[i].set == set) {
            cache[i].users--;
            pthread_mutex_unlock(&lock);
            return;
        }
    pthread_mutex_unlock(&lock);
    shadow_set *own = (shadow_set *)set;
    shadow_set_free(own);
    free(own);
}

void shadow_cache_clear(void)
{
    pthread_mutex_lock(&lock);
    for (int i = 0; i < CACHE_ENTRIES; i++)
        if (cache[i].set && !cache[i].users) {
            shadow_set_free(cache[i].set);
            free(cache[i].set);
            cache[i].set = NULL;
        }
    pthread_mutex_unlock(&lock);
}
