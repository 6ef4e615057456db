/* Cone marching on the C backend: render_cone_core.h (the portable marcher, shared with the OpenCL
 * cone kernel) with the model's cone_element called through its function pointer, timed for
 * --stats. Knows models only through models/model.h. */
#include <math.h>
#include <string.h>

#include "render_internal.h"

struct cone_ctx;
static void call_cone_element(struct cone_ctx *x, const vx_query *q, vx_answer *a);
#define CONE_ELEMENT(x, q, a) call_cone_element(x, q, a)
#include "render_cone_core.h"

static void call_cone_element(cone_ctx *x, const vx_query *q, vx_answer *a)
{
    uint64_t c0 = cycles();
    x->m->cone_element(q, a);
    x->model_cycles += cycles() - c0;
}

vec3 cone_trace_ray(const render_job *j, vec3 org, vec3 dir, thread_counts *tc)
{
    const scene *s = j->s;
    tc->rays++;
    cone_ctx x;
    memset(&x, 0, sizeof x);
    x.g = j->g;
    x.skip = j->skip;
    x.records = j->records;
    x.table = j->model_table;
    x.lcache = j->light_cache;
    x.light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    for (int li = 0; li < x.light_count; li++)
        x.lights[li] = s->lights[li];
    x.effects = s->effects;
    x.m = j->m;
    /* (org, dir) is the pixel's centre ray from the lens centre (render_row): the cone covers the
     * pixel's footprint and, with depth of field, the lens by its width. */
    int dof = (s->effects & EFFECT_DOF) && s->camera.aperture_radius > 0.0f;
    vec3 c = cone_trace(&x, org, dir, j->spread, dof ? s->camera.aperture_radius : 0.0f, s->camera.focus_distance,
                        s->camera.forward, s->background);
    tc->voxel_visits += x.counts.elements;
    tc->shadow_rays += x.counts.shadow_rays;
    tc->model_evals += x.counts.evals;
    tc->cache_hits += x.counts.cache_hits;
    tc->model_cycles += x.model_cycles;
    return c;
}
