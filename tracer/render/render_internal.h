/* Internals shared by the voxel tracer's files (render.c: voxel marching; render_cone.c: cone
 * marching for models that declare VX_MARCH_CONE). Not part of the public interface. */
#ifndef VX_RENDER_INTERNAL_H
#define VX_RENDER_INTERNAL_H

#include <stdatomic.h>

#include "cone_light_cache.h"
#include "cone_skip.h"
#include "parallel.h"
#include "render.h"

#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
static inline uint64_t cycles(void) { return __rdtsc(); }
#else
static inline uint64_t cycles(void) { return (uint64_t)(now_seconds() * 1e9); }
#endif

/* A voxel's cached answer for the direction voxel -> camera. state: 0 empty, 1 being computed,
 * 2 ready. The value depends only on the voxel, so whichever thread computes it writes the same
 * numbers: the image stays independent of the thread count. */
typedef struct {
    vec3 radiance;
    float opacity;
    unsigned int mask[VX_MASK_WORDS];
    atomic_int state;
} cache_entry;

typedef struct {
    uint64_t rays, shadow_rays, voxel_visits, model_evals, cache_hits, model_cycles, total_cycles;
    char pad[64];
} thread_counts;

typedef struct {
    const scene *s;
    const voxel_grid *g;
    const vx_model *m;
    const unsigned char *records;
    const render_options *o;
    image *out;
    cache_entry *cache;
    thread_counts *tc;
    float spread; /* footprint radius per unit distance */
    cone_light_cache *light_cache; /* cone marching with shadows and the cache on; else NULL */
    const dilated_grid *skip;      /* cone marching: the empty-space bitmaps; else NULL */
    const void *model_table;       /* the model's constant table (vx_model.table) or NULL */
} render_job;

const void *record_of(const render_job *j, int64_t index);
/* Transmittance from p toward a light through the level-0 voxels (the model's own opacity). */
float shadow_transmittance(const render_job *j, vx_query *q, int64_t self, vec3 p, vec3 to_light, float distance,
                           thread_counts *tc);
/* Fills q's lights for a point c (shadows applied when the scene declares them; self = the voxel
 * to ignore, or -1). */
void gather_lights(const render_job *j, vx_query *q, int64_t self, vec3 c, thread_counts *tc);
/* One camera ray through a VX_MARCH_CONE model (render_cone.c). */
vec3 cone_trace_ray(const render_job *j, vec3 org, vec3 dir, thread_counts *tc);

#endif
