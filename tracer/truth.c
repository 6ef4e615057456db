#include "truth.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "parallel.h"
#include "rng.h"
#include "strata.h"

#define PACKET 16

typedef struct {
    const rt_scene *rt;
    const truth_options *o;
    image *out;
    truth_counts *per_thread;
} truth_job;

static int gcd(int a, int b)
{
    while (b) {
        int t = a % b;
        a = b;
        b = t;
    }
    return a;
}

/* Traces up to 16 samples of one pixel and adds their radiance to sum. */
static void trace_packet(const rt_scene *rt, const truth_options *o, int px, int py, int first, int count, rng *r,
                         vec3 *sum, truth_counts *counts)
{
    int strata_x, strata_y;
    truth_strata(o->spp, &strata_x, &strata_y);
    const scene *s = rt->scene;
    int dof = (s->effects & EFFECT_DOF) != 0;
    /* The lens is stratified too, with its strata visited in a different order than the pixel's
     * (an affine permutation i -> (a i + b) mod m with a coprime to m and b per pixel), so pixel
     * and lens positions stay decorrelated. */
    int m = strata_x * strata_y, lens_a = m / 2 + 1, lens_b = 0;
    if (dof) {
        while (gcd(lens_a, m) != 1)
            lens_a++;
        lens_b = (int)(rng_mix64((uint64_t)py * 0x9e3779b97f4a7c15ULL + (uint64_t)px) % (uint64_t)m);
    }
    struct RTCRayHit16 rh;
    int valid[PACKET] __attribute__((aligned(64)));
    vec3 dirs[PACKET];
    for (int k = 0; k < PACKET; k++) {
        valid[k] = k < count ? -1 : 0;
        float sx = 0, sy = 0, lu = 0, lv = 0;
        if (k < count) {
            float r1 = rng_float(r), r2 = rng_float(r);
            truth_strata_sample(first + k, strata_x, strata_y, r1, r2, &sx, &sy);
            if (dof) {
                float r3 = rng_float(r), r4 = rng_float(r);
                int i = first + k;
                truth_strata_sample(i < m ? (int)(((int64_t)lens_a * i + lens_b) % m) : i, strata_x, strata_y, r3,
                                    r4, &lu, &lv);
            }
        }
        vec3 org, dir;
        camera_ray(&s->camera, o->width, o->height, (float)px + sx, (float)py + sy, lu, lv, dof, &org, &dir);
        dirs[k] = dir;
        rt_packet_rayhit(&rh, k, org, dir, 0.0f, INFINITY);
    }
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    rtcIntersect16(valid, rt->bvh, &ctx, &rh);
    counts->primary_rays += (uint64_t)count;

    surface_hit hits[PACKET];
    int hit[PACKET];
    for (int k = 0; k < count; k++) {
        hit[k] = rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
        if (hit[k])
            rt_surface(rt, rh.hit.primID[k], rh.hit.u[k], rh.hit.v[k],
                       v3(rh.ray.org_x[k], rh.ray.org_y[k], rh.ray.org_z[k]), dirs[k], rh.ray.tfar[k], &hits[k]);
        else
            sum[0] = v3_add(sum[0], s->background);
    }
    int shadows = (s->effects & EFFECT_SHADOWS) != 0;
    for (int li = 0; li < s->light_count; li++) {
        vec3 to_light[PACKET], irr[PACKET];
        int lit[PACKET];
        struct RTCRay16 sr;
        int svalid[PACKET] __attribute__((aligned(64)));
        int nshadow = 0;
        for (int k = 0; k < PACKET; k++) {
            svalid[k] = 0;
            lit[k] = 0;
            if (k >= count || !hit[k] || !hits[k].shaded)
                continue;
            float dist;
            light_at(&s->lights[li], hits[k].position, &to_light[k], &irr[k], &dist);
            vec3 side = hits[k].front_facing ? hits[k].geometric_normal : v3_scale(hits[k].geometric_normal, -1.0f);
            if (v3_dot(side, to_light[k]) <= 0.0f || v3_dot(hits[k].normal, to_light[k]) <= 0.0f)
                continue; /* faces away: no light, and no shadow ray needed */
            lit[k] = 1;
            if (!shadows)
                continue;
            vec3 org = v3_madd(hits[k].position, side, rt->epsilon);
            rt_packet_ray(&sr, k, org, to_light[k], 0.0f, isinf(dist) ? INFINITY : dist * (1.0f - 1e-5f));
            svalid[k] = -1;
            nshadow++;
        }
        if (nshadow) {
            struct RTCIntersectContext sctx;
            rtcInitIntersectContext(&sctx);
            /* One pixel's shadow rays start within the pixel's footprint and head for the same
             * light: a coherent packet, which Embree traverses together. */
            sctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            rtcOccluded16(svalid, rt->bvh, &sctx, &sr);
            counts->shadow_rays += (uint64_t)nshadow;
            for (int k = 0; k < count; k++)
                if (svalid[k] && sr.tfar[k] < 0.0f) /* Embree sets tfar = -inf for occluded rays */
                    lit[k] = 0;
        }
        for (int k = 0; k < count; k++)
            if (lit[k])
                sum[0] = v3_add(sum[0], rt_shade_light(s, &hits[k], v3_scale(dirs[k], -1.0f), to_light[k], irr[k]));
    }
}

static void render_row(void *p, int64_t row, int thread)
{
    truth_job *j = p;
    const truth_options *o = j->o;
    truth_counts *counts = &j->per_thread[thread];
    int py = (int)row;
    for (int px = 0; px < o->width; px++) {
        rng r = rng_seed(o->seed, (uint64_t)py * (uint64_t)o->width + (uint64_t)px);
        vec3 sum = v3(0, 0, 0);
        for (int first = 0; first < o->spp; first += PACKET) {
            int n = o->spp - first < PACKET ? o->spp - first : PACKET;
            trace_packet(j->rt, o, px, py, first, n, &r, &sum, counts);
        }
        float *dst = &j->out->data[3 * ((size_t)py * (size_t)o->width + (size_t)px)];
        dst[0] = sum.x / (float)o->spp;
        dst[1] = sum.y / (float)o->spp;
        dst[2] = sum.z / (float)o->spp;
    }
}

int truth_render(const rt_scene *rt, const truth_options *o, image *out, truth_counts *counts, vx_err *e)
{
    if (o->spp < 1)
        return vx_fail(e, "--spp %d: expected at least 1 sample per pixel", o->spp);
    if (image_alloc(out, o->width, o->height, 3, e))
        return -1;
    int threads = parallel_threads(o->threads);
    truth_counts *per_thread = calloc((size_t)threads, sizeof(truth_counts));
    truth_job j = {rt, o, out, per_thread};
    double t0 = now_seconds();
    parallel_for(o->height, threads, render_row, &j, o->progress ? "truth" : NULL);
    memset(counts, 0, sizeof *counts);
    counts->seconds = now_seconds() - t0;
    for (int t = 0; t < threads; t++) {
        counts->primary_rays += per_thread[t].primary_rays;
        counts->shadow_rays += per_thread[t].shadow_rays;
    }
    free(per_thread);
    return 0;
}
