/* Cone marching on the C backend: render_cone_core.h (the portable marcher, shared with the OpenCL
 * cone kernel) with the model's cone element called through its function pointer, timed for
 * --stats. Knows models only through models/model.h. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "cone_light_cache.h"
#include "cone_skip.h"
#include "render_internal.h"

struct cone_ctx;
static void call_cone_element(struct cone_ctx *x, const vx_query *q, vx_answer *a);
#define CONE_ELEMENT(x, q, a) call_cone_element(x, q, a)
#include "render_cone_core.h"

static void call_cone_element(cone_ctx *x, const vx_query *q, vx_answer *a)
{
    MODEL_CALL(x, x->m->cone->element.fn(q, a));
}

/* The marcher's state: the empty-space bitmaps, the model's table and (with shadows and the cache
 * on) the light cache, which replaces the voxel marcher's shading cache (a cone's answers depend on
 * its width, its light cones' do not). */
typedef struct {
    dilated_grid skip;
    const void *table;
    cone_light_cache lc;
    int use_lc;
} cone_state;

static int cone_prepare(render_job *j, vx_err *e)
{
    const scene *s = j->s;
    cone_state *st = calloc(1, sizeof *st);
    if (!st)
        return vx_fail(e, "out of memory for the render");
    size_t table_bytes = 0;
    st->table = j->m->cone->table ? j->m->cone->table(&table_bytes) : NULL;
    /* (Not with precomputed shadow maps: they replace the light cones.) */
    st->use_lc = j->o->cache && (s->effects & EFFECT_SHADOWS) && s->light_count > 0 && !j->shadows;
    if (st->use_lc) {
        /* Sized as the OpenCL backend's (tracer/backends/opencl/opencl_cone.c). */
        size_t cells = cone_light_cache_cells(grid_count(j->g, 0), (size_t)j->o->width * (size_t)j->o->height);
        if (cone_light_cache_init(&st->lc, cells, s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS)) {
            free(st);
            return vx_fail(e, "out of memory for the cone light cache");
        }
        j->cache_bytes = cone_light_cache_bytes(&st->lc);
    }
    if (dilated_build(&st->skip, j->g)) {
        if (st->use_lc)
            cone_light_cache_free(&st->lc);
        free(st);
        return vx_fail(e, "out of memory for the cone marcher's occupancy bitmaps");
    }
    j->state = st;
    return 0;
}

/* One cone per pixel, through the pixel's centre and the lens centre, whatever --spp says: a cone
 * covers the whole pixel footprint (and the lens, through its width). */
static void cone_row(void *p, int64_t row, int thread)
{
    render_job *j = p;
    const render_options *o = j->o;
    const scene *s = j->s;
    cone_state *st = j->state;
    thread_counts *tc = &j->tc[thread];
    int timed = render_row_timed(row);
    uint64_t c0 = timed ? cycles() : 0;
    int py = (int)row;
    int dof = (s->effects & EFFECT_DOF) && s->camera.aperture_radius > 0.0f;
    for (int px = 0; px < o->width; px++) {
        vec3 org, dir;
        camera_ray(&s->camera, o->width, o->height, (float)px + 0.5f, (float)py + 0.5f, 0.5f, 0.5f, 0, &org, &dir);
        tc->rays++;
        cone_ctx x;
        memset(&x, 0, sizeof x);
        x.g = j->g;
        x.skip = &st->skip;
        x.records = j->records;
        x.table = st->table;
        x.lcache = st->use_lc ? &st->lc : NULL;
        x.light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
        for (int li = 0; li < x.light_count; li++)
            x.lights[li] = s->lights[li];
        x.effects = s->effects;
        x.m = j->m;
        x.timed = timed;
        shadow_set_view(j->shadows, &x.shadows);
        vec3 c = cone_trace(&x, org, dir, j->spread, dof ? s->camera.aperture_radius : 0.0f, s->camera.focus_distance,
                            s->camera.forward, s->background);
        tc->voxel_visits += x.counts.elements;
        tc->shadow_rays += x.counts.shadow_rays;
        tc->model_evals += x.counts.evals;
        tc->cache_hits += x.counts.cache_hits;
        tc->shadow_queries += x.shadows.queries;
        tc->model_cycles += x.model_cycles;
        float *dst = &j->out->data[3 * ((size_t)py * (size_t)o->width + (size_t)px)];
        dst[0] = c.x, dst[1] = c.y, dst[2] = c.z;
    }
    if (timed)
        tc->total_cycles += cycles() - c0;
}

static void cone_release(render_job *j)
{
    cone_state *st = j->state;
    if (!st)
        return;
    if (st->use_lc)
        cone_light_cache_free(&st->lc);
    dilated_free(&st->skip);
    free(st);
    j->state = NULL;
}

const render_marcher render_cone_marcher = {cone_prepare, NULL, cone_row, cone_release};
