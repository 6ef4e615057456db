#include "render.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "grid_traverse.h"
#include "parallel.h"
#include "render_internal.h"
#include "rng.h"
#include "strata.h"

void render_default_options(render_options *o)
{
    memset(o, 0, sizeof *o);
    o->spp = 4;
    o->seed = 1;
    o->progress = 1;
    o->cache = 1;
    o->shadow_skip = 1;
    o->stop_opacity = 1.0f - 0.001f;
}

const void *record_of(const render_job *j, int64_t index)
{
    return j->records + (size_t)index * j->m->voxel_bytes;
}

/* Transmittance from p toward light li through the voxels (the model's own opacity), skipping the
 * voxel `self` and, when asked, every voxel closer than 1.5 voxel sizes. */
float shadow_transmittance(const render_job *j, vx_query *q, int64_t self, vec3 p, vec3 to_light,
                                  float distance, thread_counts *tc)
{
    const voxel_grid *g = j->g;
    float t_min = j->o->shadow_skip ? 1.5f * g->voxel_size : 0.0f;
    grid_iter it;
    grid_hit h;
    float T = 1.0f;
    tc->shadow_rays++;
    if (!grid_iter_init(&it, g, 0, p, to_light, t_min, distance))
        return 1.0f;
    vx_query sq = *q;
    sq.ray_origin = p;
    sq.ray_dir = to_light;
    sq.to_viewer = v3_scale(to_light, -1.0f);
    while (grid_iter_next(&it, &h)) {
        if (h.index == self)
            continue;
        sq.t0 = h.t0;
        sq.t1 = h.t1;
        vec3 hi;
        grid_cell_box(g, 0, h.x, h.y, h.z, &sq.voxel_lo, &hi);
        uint64_t c0 = cycles();
        float a = j->m->opacity(record_of(j, h.index), &sq);
        tc->model_cycles += cycles() - c0;
        T *= 1.0f - fminf(fmaxf(a, 0.0f), 1.0f);
        if (T < 1e-4f)
            return 0.0f;
    }
    return T;
}

/* Fills q's lights for a voxel centred at c (shadows applied when declared). */
void gather_lights(const render_job *j, vx_query *q, int64_t self, vec3 c, thread_counts *tc)
{
    const scene *s = j->s;
    q->light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    for (int li = 0; li < q->light_count; li++) {
        vec3 dir, irr;
        float dist;
        light_at(&s->lights[li], c, &dir, &irr, &dist);
        if (s->effects & EFFECT_SHADOWS)
            irr = v3_scale(irr, shadow_transmittance(j, q, self, c, dir, dist, tc));
        q->to_light[li] = dir;
        q->irradiance[li] = irr;
    }
}

/* The model's answer for one voxel along one ray (or for the cached direction voxel -> camera). */
static void evaluate(const render_job *j, vx_query *q, int64_t index, vec3 centre, vx_answer *a, thread_counts *tc)
{
    const void *rec = record_of(j, index);
    uint64_t c0 = cycles();
    a->opacity = j->m->opacity(rec, q);
    tc->model_cycles += cycles() - c0;
    a->radiance = v3(0, 0, 0);
    for (int w = 0; w < VX_MASK_WORDS; w++)
        a->mask[w] = 0;
    tc->model_evals++;
    if (!(a->opacity > 0.0f))
        return;
    gather_lights(j, q, index, centre, tc);
    c0 = cycles();
    j->m->shade(rec, q, a);
    tc->model_cycles += cycles() - c0;
}

static void answer_for_voxel(const render_job *j, const grid_hit *h, vec3 org, vec3 dir, vx_answer *a,
                             thread_counts *tc)
{
    const voxel_grid *g = j->g;
    const scene *s = j->s;
    vx_query q;
    memset(&q, 0, sizeof q);
    vec3 hi;
    grid_cell_box(g, 0, h->x, h->y, h->z, &q.voxel_lo, &hi);
    vec3 centre = v3_scale(v3_add(q.voxel_lo, hi), 0.5f);
    q.voxel_size = g->voxel_size;
    q.effects = s->effects;
    if (j->cache) {
        cache_entry *ce = &j->cache[h->index];
        if (atomic_load_explicit(&ce->state, memory_order_acquire) == 2) {
            tc->cache_hits++;
            a->radiance = ce->radiance;
            a->opacity = ce->opacity;
            memcpy(a->mask, ce->mask, sizeof a->mask);
            return;
        }
        /* The cached direction: from the voxel's centre toward the camera. */
        vec3 to_cam = v3_sub(s->camera.position, centre);
        float dist = v3_length(to_cam);
        q.to_viewer = v3_normalize_or(to_cam, v3_scale(dir, -1.0f));
        q.ray_dir = v3_scale(q.to_viewer, -1.0f);
        q.ray_origin = s->camera.position;
        q.t0 = dist - 0.5f * g->voxel_size;
        q.t1 = dist + 0.5f * g->voxel_size;
        q.footprint = dist * j->spread;
        evaluate(j, &q, h->index, centre, a, tc);
        int expected = 0;
        if (atomic_compare_exchange_strong(&ce->state, &expected, 1)) {
            ce->radiance = a->radiance;
            ce->opacity = a->opacity;
            memcpy(ce->mask, a->mask, sizeof a->mask);
            atomic_store_explicit(&ce->state, 2, memory_order_release);
        }
        return;
    }
    q.to_viewer = v3_scale(dir, -1.0f);
    q.ray_origin = org;
    q.ray_dir = dir;
    q.t0 = h->t0;
    q.t1 = h->t1;
    float tm = 0.5f * (h->t0 + h->t1);
    q.footprint = tm * j->spread;
    if ((s->effects & EFFECT_DOF) && s->camera.aperture_radius > 0.0f)
        q.footprint += s->camera.aperture_radius * fabsf(tm - s->camera.focus_distance) / s->camera.focus_distance;
    evaluate(j, &q, h->index, centre, a, tc);
}

static vec3 trace_ray(const render_job *j, vec3 org, vec3 dir, thread_counts *tc)
{
    const vx_model *m = j->m;
    const scene *s = j->s;
    vec3 color = v3(0, 0, 0);
    float A = 0.0f;
    unsigned int covered[VX_MASK_WORDS] = {0, 0, 0, 0};
    int done = 0;
    grid_iter it;
    grid_hit h;
    tc->rays++;
    if (grid_iter_init(&it, j->g, 0, org, dir, 0.0f, INFINITY)) {
        while (!done && grid_iter_next(&it, &h)) {
            tc->voxel_visits++;
            vx_answer a;
            answer_for_voxel(j, &h, org, dir, &a, tc);
            float alpha = fminf(fmaxf(a.opacity, 0.0f), 1.0f);
            if (!(alpha > 0.0f))
                continue;
            switch (m->compositing) {
            case VX_COMPOSITE_FIRST_HIT:
                color = a.radiance;
                A = 1.0f;
                done = 1;
                break;
            case VX_COMPOSITE_ALPHA:
                color = v3_madd(color, a.radiance, (1.0f - A) * alpha);
                A += (1.0f - A) * alpha;
                done = A >= j->o->stop_opacity;
                break;
            default: { /* VX_COMPOSITE_COVERAGE */
                int fresh = 0, total = 0;
                for (int w = 0; w < VX_MASK_WORDS; w++) {
                    fresh += __builtin_popcount(a.mask[w] & ~covered[w]);
                    covered[w] |= a.mask[w];
                    total += __builtin_popcount(covered[w]);
                }
                color = v3_madd(color, a.radiance, (float)fresh / (32.0f * VX_MASK_WORDS));
                A = (float)total / (32.0f * VX_MASK_WORDS);
                done = total == 32 * VX_MASK_WORDS;
            }
            }
        }
    }
    return v3_madd(color, s->background, 1.0f - A);
}

static void render_row(void *p, int64_t row, int thread)
{
    render_job *j = p;
    const render_options *o = j->o;
    const scene *s = j->s;
    thread_counts *tc = &j->tc[thread];
    uint64_t c0 = cycles();
    int dof = (s->effects & EFFECT_DOF) != 0;
    int py = (int)row;
    for (int px = 0; px < o->width; px++) {
        rng r = rng_seed(o->seed, (uint64_t)py * (uint64_t)o->width + (uint64_t)px);
        vec3 sum = v3(0, 0, 0);
        float *dst = &j->out->data[3 * ((size_t)py * (size_t)o->width + (size_t)px)];
        if (j->m->march == VX_MARCH_CONE) {
            /* A cone covers the whole pixel footprint (and the lens, through its width): one cone
             * per pixel, through the pixel's centre and the lens centre, whatever --spp says. */
            vec3 org, dir;
            camera_ray(&s->camera, o->width, o->height, (float)px + 0.5f, (float)py + 0.5f, 0.5f, 0.5f, 0, &org, &dir);
            vec3 c = cone_trace_ray(j, org, dir, tc);
            dst[0] = c.x, dst[1] = c.y, dst[2] = c.z;
            continue;
        }
        for (int i = 0; i < o->spp; i++) {
            float sx, sy, lu = 0, lv = 0;
            float r1 = rng_float(&r), r2 = rng_float(&r);
            truth_stratified_sample(i, o->spp, r1, r2, &sx, &sy);
            if (dof) {
                lu = rng_float(&r);
                lv = rng_float(&r);
            }
            vec3 org, dir;
            camera_ray(&s->camera, o->width, o->height, (float)px + sx, (float)py + sy, lu, lv, dof, &org, &dir);
            sum = v3_add(sum, trace_ray(j, org, dir, tc));
        }
        dst[0] = sum.x / (float)o->spp;
        dst[1] = sum.y / (float)o->spp;
        dst[2] = sum.z / (float)o->spp;
    }
    tc->total_cycles += cycles() - c0;
}

int render_image(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                 const render_options *o, image *out, render_counts *counts, vx_err *e)
{
    if (o->spp < 1)
        return vx_fail(e, "--spp %d: expected at least 1 ray per pixel", o->spp);
    if (m->march == VX_MARCH_CONE && !m->cone_element)
        return vx_fail(e, "model %s: declares cone marching without a cone_element function", m->name);
    if (image_alloc(out, o->width, o->height, 3, e))
        return -1;
    int threads = parallel_threads(o->threads);
    render_job j = {s, g, m, records, o, out, NULL, calloc((size_t)threads, sizeof(thread_counts)),
                    camera_pixel_spread(&s->camera, o->height), NULL, NULL, NULL};
    int cone = m->march == VX_MARCH_CONE;
    size_t table_bytes = 0;
    j.model_table = m->table ? m->table(&table_bytes) : NULL;
    if (o->cache && !cone)
        j.cache = calloc(grid_count(g, 0) ? grid_count(g, 0) : 1, sizeof(cache_entry));
    /* Cone marching caches the light cones instead (the cone's answers depend on its width). */
    cone_light_cache lc;
    int use_lc = o->cache && cone && (s->effects & EFFECT_SHADOWS) && s->light_count > 0;
    int lc_failed = 0;
    if (use_lc) {
        /* Sized as the OpenCL backend's (tracer/backends/opencl/opencl_cone.c). */
        size_t cells = cone_light_cache_cells(grid_count(g, 0), (size_t)o->width * (size_t)o->height);
        lc_failed = cone_light_cache_init(&lc, cells, s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS);
        j.light_cache = lc_failed ? NULL : &lc;
    }
    dilated_grid skip;
    int skip_failed = 0;
    if (cone) {
        skip_failed = dilated_build(&skip, g);
        j.skip = &skip;
    }
    if (!j.tc || (o->cache && !cone && !j.cache) || lc_failed || skip_failed) {
        free(j.tc);
        free(j.cache);
        if (j.light_cache)
            cone_light_cache_free(j.light_cache);
        if (cone && !skip_failed)
            dilated_free(&skip);
        image_free(out);
        return vx_fail(e, "out of memory for the render");
    }
    double t0 = now_seconds();
    parallel_for(o->height, threads, render_row, &j, o->progress ? "render" : NULL);
    memset(counts, 0, sizeof *counts);
    counts->seconds = now_seconds() - t0;
    uint64_t model_cycles = 0, total_cycles = 0;
    for (int t = 0; t < threads; t++) {
        counts->rays += j.tc[t].rays;
        counts->shadow_rays += j.tc[t].shadow_rays;
        counts->voxel_visits += j.tc[t].voxel_visits;
        counts->model_evals += j.tc[t].model_evals;
        counts->cache_hits += j.tc[t].cache_hits;
        model_cycles += j.tc[t].model_cycles;
        total_cycles += j.tc[t].total_cycles;
    }
    double frac = total_cycles ? (double)model_cycles / (double)total_cycles : 0.0;
    counts->model_seconds = counts->seconds * frac;
    counts->traversal_seconds = counts->seconds - counts->model_seconds;
    free(j.tc);
    free(j.cache);
    if (j.light_cache)
        cone_light_cache_free(j.light_cache);
    if (cone)
        dilated_free(&skip);
    return 0;
}
