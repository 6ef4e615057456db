/* Cone marching on the C backend: render_cone_core.h (the portable marcher, shared with the OpenCL
 * cone kernel) with the model's cone element called through its function pointer, timed for
 * --stats. Knows models only through models/model.h. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "cone_camera_ends.h"
#include "cone_light_cache.h"
#include "cone_skip.h"
#include "render_internal.h"
#include "shadow_clip.h"

struct cone_ctx;
static void call_cone_element(struct cone_ctx *x, const vx_query *q, vx_answer *a);
static float cone_light_end(const struct cone_ctx *x, vec3 org, vec3 dir, float r, int straight, float t_end);
#define CONE_ELEMENT(x, q, a) call_cone_element(x, q, a)
#define CONE_LIGHT_END(x, c, t_end)                                                                                 \
    cone_light_end(x, (c)->org, (c)->dir, cone_radius((c), 0.0f), (c)->spread == 0.0f && (c)->aperture == 0.0f, t_end)
#define CONE_CAMERA_END(x, t_end) vx_fminf((t_end), (x)->camera_end)
#include "render_cone_core.h"

static void call_cone_element(cone_ctx *x, const vx_query *q, vx_answer *a)
{
    MODEL_CALL(x, x->m->cone->element.fn(q, a));
}

/* The light cones' ends (CONE_LIGHT_END, render_cone_core.h): per directional light, shadow_clip.h's
 * map of the non-empty cells of MIP levels 1 .. CONE_CLIP_LEVELS, each grown into the cube of its
 * 3x3x3 neighbourhood (edge 3). The marcher asks the model about an element exactly when the
 * element's cell on the proof level (cone_proof_level) has a non-empty neighbour, that is when the
 * element's centre lies in one of those cubes; a light cone is straight and keeps its width, so
 * past the last cube in its column toward the light it asks about nothing more, and its walk ends
 * there instead of climbing out of the grid (bunny 256^3: 1.07 of heitz-neyret's 2.76 million
 * empty-space jumps a frame, 27 thousand of the 55 thousand light cones asking about nothing).
 * The centres are floats (org + t dir, two roundings a coordinate) while the map places the exact
 * line: the maps hold SHADOW_CLIP_CONE_SLACK of a cell more on every side, and a cone whose rounding could
 * exceed that walks to the grid's edge as before. Levels: a cached light cone is as wide as an
 * element of level L + 1/2 (cone_cached_transmittance, L the camera element's level), so its proof
 * level is L + 1, and most are 1. */
#define CONE_CLIP_LEVELS 3

struct cone_light_clips {
    shadow_clip map[VX_MAX_LIGHTS][CONE_CLIP_LEVELS]; /* [light][level - 1]; g NULL: none */
};

static float cone_light_end(const cone_ctx *x, vec3 org, vec3 dir, float r, int straight, float t_end)
{
    if (!x->clips || !straight || !(t_end < INFINITY))
        return t_end;
    const voxel_grid *g = x->g;
    int top = g->levels - 1;
    int K = cone_proof_level(cone_element_level(r, 2.0f / g->voxel_size, top), top); /* cone_walk_start's scale */
    if (K < 1 || K > CONE_CLIP_LEVELS)
        return t_end;
    /* The rounding of a centre org + t dir (|dir| <= 1 a coordinate, t below t_end + r): at most
     * half an ulp of dir t and of the sum, (|org| + 2 t) 2^-24 a coordinate; twice that, in cells. */
    double far = (double)vx_fmaxf(vx_fmaxf(fabsf(org.x), fabsf(org.y)), fabsf(org.z)) + 2.0 * ((double)t_end + r);
    if (!(far * 0x1p-23 <= SHADOW_CLIP_CONE_SLACK * g->voxel_size_d * (double)(1u << K)))
        return t_end;
    for (int li = 0; li < VX_MAX_LIGHTS; li++) {
        const shadow_clip *m = &x->clips->map[li][K - 1];
        if (m->g && dir.x == m->built_for.x && dir.y == m->built_for.y && dir.z == m->built_for.z) {
            double o[3];
            grid_to_lattice(g, org, o);
            return shadow_clip_end_lattice(m, o, dir, t_end);
        }
    }
    return t_end;
}

static void cone_clips_free(struct cone_light_clips *c)
{
    for (int li = 0; li < VX_MAX_LIGHTS; li++)
        for (int k = 0; k < CONE_CLIP_LEVELS; k++)
            shadow_clip_free(&c->map[li][k]);
}

/* The maps of every directional light (shadows declared and marched, the option on); 0, or -1 when
 * out of memory. */
static int cone_clips_build(render_job *j, struct cone_light_clips *c)
{
    const scene *s = j->s;
    for (int li = 0; li < s->light_count && li < VX_MAX_LIGHTS; li++) {
        if (s->lights[li].type != LIGHT_DIRECTIONAL)
            continue;
        for (int k = 1; k <= CONE_CLIP_LEVELS && k < j->g->levels; k++) {
            shadow_clip *m = &c->map[li][k - 1];
            if (shadow_clip_build_cells(m, j->g, k, SHADOW_CLIP_CONE_SIDE, SHADOW_CLIP_CONE_SLACK,
                                        s->lights[li].direction))
                return -1;
            j->map_bytes += shadow_clip_bytes(m);
        }
    }
    return 0;
}

/* The marcher's state: the empty-space bitmaps, the model's table and (with shadows and the cache
 * on) the light cache, which replaces the voxel marcher's shading cache (a cone's answers depend on
 * its width, its light cones' do not). */
typedef struct {
    dilated_grid skip;
    const void *table;
    cone_light_cache lc;
    int use_lc;
    struct cone_light_clips clips;
    int use_clips;
    pixel_bounds ends; /* the camera cones' ends (cone_camera_ends.h); near_t NULL: none */
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
    st->use_clips = j->o->shadow_clip && (s->effects & EFFECT_SHADOWS) && !j->shadows;
    if (st->use_clips && cone_clips_build(j, &st->clips))
        return vx_fail(e, "out of memory for the light cones' ends"); /* the caller releases st */
    if (j->o->pixel_bounds && !((s->effects & EFFECT_DOF) && s->camera.aperture_radius > 0.0f)) {
        if (pixel_bounds_alloc(&st->ends, j->o->width, j->o->height, CONE_ENDS_TILE_SHIFT,
                               parallel_threads(j->o->threads)))
            return vx_fail(e, "out of memory for the camera cones' ends");
        j->map_bytes += pixel_bounds_bytes(&st->ends);
    }
    return 0;
}

/* The frame's own set-up, inside its clock: the camera cones' ends (they depend on the camera). */
static void cone_begin(render_job *j, int threads)
{
    cone_state *st = j->state;
    if (st->ends.near_t)
        cone_camera_ends_build(&st->ends, j->g, &j->s->camera, j->spread, threads);
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
        x.clips = st->use_clips ? &st->clips : NULL;
        x.light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
        for (int li = 0; li < x.light_count; li++)
            x.lights[li] = s->lights[li];
        x.effects = s->effects;
        x.m = j->m;
        x.timed = timed;
        shadow_set_view(j->shadows, &x.shadows);
        x.camera_end = cone_camera_end(&st->ends, s->camera.forward, px, py, dir);
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
    cone_clips_free(&st->clips);
    pixel_bounds_free(&st->ends);
    dilated_free(&st->skip);
    free(st);
    j->state = NULL;
}

const render_marcher render_cone_marcher = {cone_prepare, cone_begin, cone_row, cone_release};
