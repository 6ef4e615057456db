#include "truth.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "parallel.h"
#include "prefault.h"
#include "rng.h"
#include "shading.h"
#include "strata.h"

#define PACKET 16

/* What a render keeps fixed: worked out once instead of per packet. */
typedef struct {
    const rt_scene *rt;
    const truth_options *o;
    image *out;
    truth_counts *per_thread;
    int strata_x, strata_y;
    int dof, shadows, specular;
    int lens_a; /* multiplier of the lens strata permutation, coprime to the strata count */
    const shadow_set *maps; /* --shadows slicemap: the light-space slicemaps instead of shadow rays */
} truth_job;

/* Running sums kept per packet lane, so the shading loops add lane by lane without a float
 * reduction (which the compiler may not vectorise without reordering); a pixel's are summed once at
 * the end over its own lanes in lane order. Misses are counted per lane and the background added
 * once per pixel. */
typedef struct {
    float r[PACKET], g[PACKET], b[PACKET];
    int misses[PACKET];
} pixel_sums;

/* The surfaces a packet hit, as a structure of arrays so the per-light loops run over all lanes
 * at once. A lane that missed, is beyond the packet's count or hit the back of a single-sided
 * surface (a black occluder) has shaded = 0 and zeros elsewhere: it never gets light. */
typedef struct {
    float px[PACKET], py[PACKET], pz[PACKET]; /* hit point */
    float nx[PACKET], ny[PACKET], nz[PACKET]; /* unit shading normal, on the viewer's side */
    float gx[PACKET], gy[PACKET], gz[PACKET]; /* unit geometric normal, on the viewer's side */
    float fr[PACKET], fg[PACKET], fb[PACKET]; /* Lambert BRDF: albedo / pi */
    int shaded[PACKET];
    const material *material[PACKET];
} packet_surfaces;

/* One light as seen from each lane's hit point. */
typedef struct {
    float lx[PACKET], ly[PACKET], lz[PACKET]; /* unit direction toward the light */
    float er[PACKET], eg[PACKET], eb[PACKET]; /* irradiance on a facing surface */
    float tfar[PACKET];                       /* where a shadow ray stops short of the light */
} packet_light;

static int gcd(int a, int b)
{
    while (b) {
        int t = a % b;
        a = b;
        b = t;
    }
    return a;
}

/* How far a shadow ray from a hit at org + t dir starts off the surface: the scene's epsilon (rt.c:
 * its size and its distance from the origin), or more where the hit point's own rounding is larger.
 * That point is org + t dir in floats, Embree's t carries a few ulps of error too, so the point is off
 * by a few ulps of |org| + t |dir|, whatever the scene's size: with a camera far from the scene
 * (10^4 away from a plate 20 wide) the scene's epsilon alone was smaller than that, and a lit plate
 * shadowed itself in speckles (mean 0.87 where nothing casts a shadow; the audit of issue 15's stop
 * 43). 1e-6 is about 17 ulps of that sum; for the shipped scenes the scene's epsilon is the larger. */
static float shadow_offset(float scene_eps, vec3 org, vec3 dir, float t)
{
    float o = vx_fmaxf(fabsf(org.x), vx_fmaxf(fabsf(org.y), fabsf(org.z)));
    float d = vx_fmaxf(fabsf(dir.x), vx_fmaxf(fabsf(dir.y), fabsf(dir.z)));
    return vx_fmaxf(scene_eps, SCENE_HIT_ROUNDING * (o + t * d));
}

/* Each lane's hit (rt_surface, as the bake sampler sees it) laid out for the per-light loops; misses
 * are counted for the background. */
static void describe_surfaces(const truth_job *j, const struct RTCRayHit16 *rh, int count, packet_surfaces *h,
                              pixel_sums *sums)
{
    const rt_scene *rt = j->rt;
    memset(h, 0, sizeof *h);
    for (int k = 0; k < count; k++) {
        if (rh->hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
            sums->misses[k]++;
            continue;
        }
        vec3 org = v3(rh->ray.org_x[k], rh->ray.org_y[k], rh->ray.org_z[k]);
        vec3 dir = v3(rh->ray.dir_x[k], rh->ray.dir_y[k], rh->ray.dir_z[k]);
        surface_hit sh;
        rt_surface(rt, rh->hit.instID[0][k], rh->hit.primID[k], rh->hit.u[k], rh->hit.v[k], org, dir, rh->ray.tfar[k], &sh);
        if (!sh.shaded)
            continue;
        vec3 side = sh.front_facing ? sh.geometric_normal : v3_scale(sh.geometric_normal, -1.0f);
        h->px[k] = sh.position.x, h->py[k] = sh.position.y, h->pz[k] = sh.position.z;
        h->nx[k] = sh.normal.x, h->ny[k] = sh.normal.y, h->nz[k] = sh.normal.z;
        h->gx[k] = side.x, h->gy[k] = side.y, h->gz[k] = side.z;
        h->fr[k] = sh.albedo.x * (1.0f / VX_PI);
        h->fg[k] = sh.albedo.y * (1.0f / VX_PI);
        h->fb[k] = sh.albedo.z * (1.0f / VX_PI);
        h->material[k] = sh.material;
        h->shaded[k] = 1;
    }
}

/* Direction, irradiance and shadow-ray extent of light L at every lane's hit point. A directional
 * light's are the same everywhere. */
static void light_lanes(const light *L, const packet_surfaces *h, packet_light *pl)
{
    if (L->type == LIGHT_DIRECTIONAL) {
        for (int k = 0; k < PACKET; k++) {
            pl->lx[k] = L->direction.x, pl->ly[k] = L->direction.y, pl->lz[k] = L->direction.z;
            pl->er[k] = L->radiance.x, pl->eg[k] = L->radiance.y, pl->eb[k] = L->radiance.z;
            pl->tfar[k] = INFINITY;
        }
        return;
    }
    for (int k = 0; k < PACKET; k++) {
        vec3 to_light, irradiance;
        float dist;
        light_at(L, v3(h->px[k], h->py[k], h->pz[k]), &to_light, &irradiance, &dist);
        pl->lx[k] = to_light.x, pl->ly[k] = to_light.y, pl->lz[k] = to_light.z;
        pl->er[k] = irradiance.x, pl->eg[k] = irradiance.y, pl->eb[k] = irradiance.z;
        pl->tfar[k] = dist * (1.0f - 1e-5f);
    }
}

/* Adds one light's contribution to every lane: Lambert plus, when declared, the Beckmann lobe;
 * shadow rays (when declared) only for lanes the light faces. */
static void shade_light(const truth_job *j, int li, const struct RTCRayHit16 *rh, const packet_surfaces *h,
                        pixel_sums *sums, truth_counts *counts)
{
    const light *L = &j->rt->scene->lights[li];
    packet_light pl;
    light_lanes(L, h, &pl);
    float cos_l[PACKET];
    int lit[PACKET];
    for (int k = 0; k < PACKET; k++) {
        /* A light below the geometric surface cannot reach it, whatever the shading normal says. */
        float side = h->gx[k] * pl.lx[k] + h->gy[k] * pl.ly[k] + h->gz[k] * pl.lz[k];
        cos_l[k] = h->nx[k] * pl.lx[k] + h->ny[k] * pl.ly[k] + h->nz[k] * pl.lz[k];
        lit[k] = h->shaded[k] & (side > 0.0f) & (cos_l[k] > 0.0f);
    }
    float T[PACKET];
    for (int k = 0; k < PACKET; k++)
        T[k] = 1.0f;
    if (j->shadows && j->maps) {
        /* A comparison of shadow techniques: the triangles' slicemap (shadow_maps_core.h) queried at
         * the hit point instead of a shadow ray. */
        shadow_maps sm;
        shadow_set_view(j->maps, &sm);
        for (int k = 0; k < PACKET; k++)
            if (lit[k]) {
                T[k] = shadow_maps_transmittance(&sm, li, v3(h->px[k], h->py[k], h->pz[k]), 0.0f);
                lit[k] &= T[k] > 0.0f;
            }
        counts->shadows.queries += sm.queries;
    } else if (j->shadows) {
        struct RTCRay16 sr;
        int svalid[PACKET] __attribute__((aligned(64)));
        int nshadow = 0;
        for (int k = 0; k < PACKET; k++) {
            /* Only for the lanes that cast one (a miss's t is infinite); a scene without shadows pays
             * nothing for it. */
            vec3 org = v3(rh->ray.org_x[k], rh->ray.org_y[k], rh->ray.org_z[k]);
            vec3 dir = v3(rh->ray.dir_x[k], rh->ray.dir_y[k], rh->ray.dir_z[k]);
            float eps = lit[k] ? shadow_offset(j->rt->epsilon, org, dir, rh->ray.tfar[k]) : 0.0f;
            sr.org_x[k] = h->px[k] + h->gx[k] * eps;
            sr.org_y[k] = h->py[k] + h->gy[k] * eps;
            sr.org_z[k] = h->pz[k] + h->gz[k] * eps;
            sr.dir_x[k] = pl.lx[k], sr.dir_y[k] = pl.ly[k], sr.dir_z[k] = pl.lz[k];
            sr.tnear[k] = 0.0f;
            sr.tfar[k] = pl.tfar[k];
            sr.time[k] = 0.0f;
            sr.mask[k] = 0xffffffffu;
            sr.id[k] = (unsigned)k;
            sr.flags[k] = 0;
            svalid[k] = -lit[k];
            nshadow += lit[k];
        }
        if (nshadow) {
            struct RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            /* One pixel's shadow rays start within the pixel's footprint and head for the same
             * light: a coherent packet, which Embree traverses together. */
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            rtcOccluded16(svalid, j->rt->bvh, &ctx, &sr);
            counts->shadow_rays += (uint64_t)nshadow;
            for (int k = 0; k < PACKET; k++)
                lit[k] &= !(sr.tfar[k] < 0.0f); /* Embree sets tfar = -inf for occluded rays */
        }
    }
    float weight[PACKET], fr[PACKET], fg[PACKET], fb[PACKET];
    for (int k = 0; k < PACKET; k++) {
        weight[k] = lit[k] ? cos_l[k] * T[k] : 0.0f;
        fr[k] = h->fr[k], fg[k] = h->fg[k], fb[k] = h->fb[k];
    }
    if (j->specular) {
        for (int k = 0; k < PACKET; k++) {
            if (!lit[k])
                continue;
            const material *mat = h->material[k];
            float spec = shading_specular_brdf(v3(h->nx[k], h->ny[k], h->nz[k]),
                                               v3(-rh->ray.dir_x[k], -rh->ray.dir_y[k], -rh->ray.dir_z[k]),
                                               v3(pl.lx[k], pl.ly[k], pl.lz[k]), mat->specular, mat->roughness);
            fr[k] += spec, fg[k] += spec, fb[k] += spec;
        }
    }
    for (int k = 0; k < PACKET; k++) {
        sums->r[k] += fr[k] * pl.er[k] * weight[k];
        sums->g[k] += fg[k] * pl.eg[k] * weight[k];
        sums->b[k] += fb[k] * pl.eb[k] * weight[k];
    }
}

/* Fills lanes [lane, lane + count) of rh with samples first.. of pixel (px, py), drawing them from
 * the pixel's random stream r in sample order. lens_b: the pixel's offset of the lens strata
 * permutation. */
static void fill_lanes(const truth_job *j, struct RTCRayHit16 *rh, int lane, int count, int px, int py, int lens_b,
                       int first, rng *r)
{
    const scene *s = j->rt->scene;
    const truth_options *o = j->o;
    int strata_x = j->strata_x, strata_y = j->strata_y, m = strata_x * strata_y;
    if (j->dof) {
        for (int k = 0; k < count; k++) {
            float sx, sy, lu, lv;
            float r1 = rng_float(r), r2 = rng_float(r), r3 = rng_float(r), r4 = rng_float(r);
            int i = first + k;
            truth_strata_sample(i, strata_x, strata_y, r1, r2, &sx, &sy);
            truth_strata_sample(i < m ? (int)(((int64_t)j->lens_a * i + lens_b) % m) : i, strata_x, strata_y, r3,
                                r4, &lu, &lv);
            vec3 org, dir;
            camera_ray(&s->camera, o->width, o->height, (float)px + sx, (float)py + sy, lu, lv, 1, &org, &dir);
            rt_packet_rayhit(rh, lane + k, org, dir, 0.0f, INFINITY);
        }
    } else {
        for (int k = 0; k < count; k++) {
            float sx, sy;
            float r1 = rng_float(r), r2 = rng_float(r);
            truth_strata_sample(first + k, strata_x, strata_y, r1, r2, &sx, &sy);
            vec3 org, dir;
            camera_ray(&s->camera, o->width, o->height, (float)px + sx, (float)py + sy, 0, 0, 0, &org, &dir);
            rt_packet_rayhit(rh, lane + k, org, dir, 0.0f, INFINITY);
        }
    }
}

/* Traces the first `count` lanes of rh (filled by fill_lanes; the rest are given a copy of lane 0
 * and left invalid) and adds their radiance to sums, lane by lane. */
static void trace_lanes(const truth_job *j, struct RTCRayHit16 *rh, int count, pixel_sums *sums,
                        truth_counts *counts)
{
    const scene *s = j->rt->scene;
    int valid[PACKET] __attribute__((aligned(64)));
    for (int k = count; k < PACKET; k++)
        rt_packet_rayhit(rh, k, v3(rh->ray.org_x[0], rh->ray.org_y[0], rh->ray.org_z[0]),
                         v3(rh->ray.dir_x[0], rh->ray.dir_y[0], rh->ray.dir_z[0]), 0.0f, INFINITY);
    for (int k = 0; k < PACKET; k++)
        valid[k] = k < count ? -1 : 0;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    rtcIntersect16(valid, j->rt->bvh, &ctx, rh);
    counts->primary_rays += (uint64_t)count;

    packet_surfaces h;
    describe_surfaces(j, rh, count, &h, sums);
    for (int li = 0; li < s->light_count; li++)
        shade_light(j, li, rh, &h, sums, counts);
}

/* A pixel's colour from its lanes [lane, lane + n) of sums: the background for its misses, then
 * its lanes in order, over spp. */
static void finish_pixel(const truth_job *j, const pixel_sums *sums, int lane, int n, int px, int py)
{
    const truth_options *o = j->o;
    int misses = 0;
    for (int k = lane; k < lane + n; k++)
        misses += sums->misses[k];
    vec3 sum = v3_scale(j->rt->scene->background, (float)misses);
    for (int k = lane; k < lane + n; k++)
        sum = v3_add(sum, v3(sums->r[k], sums->g[k], sums->b[k]));
    float *dst = &j->out->data[3 * ((size_t)py * (size_t)o->width + (size_t)px)];
    dst[0] = sum.x / (float)o->spp;
    dst[1] = sum.y / (float)o->spp;
    dst[2] = sum.z / (float)o->spp;
}

/* The lens strata's offset for pixel (px, py): the lens is stratified too, with its strata visited
 * in a different order than the pixel's (an affine permutation i -> (a i + b) mod m with a coprime
 * to m and b per pixel), so pixel and lens positions stay decorrelated. */
static int lens_offset(const truth_job *j, int px, int py)
{
    int m = j->strata_x * j->strata_y;
    return j->dof ? (int)(rng_mix64((uint64_t)py * 0x9e3779b97f4a7c15ULL + (uint64_t)px) % (uint64_t)m) : 0;
}

/* One row. From 16 samples per pixel up, a pixel's samples fill whole packets; below, a packet
 * holds the samples of several neighbouring pixels (16 / spp of them), so that no lane idles (at 4
 * spp one pixel per packet left 12 of 16 lanes empty). Each pixel's rays, random numbers and sums
 * are its own whichever packet carries them: the image is the same either way. */
static void render_row(void *p, int64_t row, int thread)
{
    truth_job *j = p;
    const truth_options *o = j->o;
    /* Counted here and added to the thread's total once per row: the threads' totals share a
     * cache line, and updating them per packet made the cores pass it back and forth. */
    truth_counts counts = {0};
    int py = (int)row;
    struct RTCRayHit16 rh;
    pixel_sums sums;
    if (o->spp >= PACKET) {
        for (int px = 0; px < o->width; px++) {
            rng r = rng_seed(o->seed, (uint64_t)py * (uint64_t)o->width + (uint64_t)px);
            int lens_b = lens_offset(j, px, py);
            memset(&sums, 0, sizeof sums);
            for (int first = 0; first < o->spp; first += PACKET) {
                int n = o->spp - first < PACKET ? o->spp - first : PACKET;
                fill_lanes(j, &rh, 0, n, px, py, lens_b, first, &r);
                trace_lanes(j, &rh, n, &sums, &counts);
            }
            finish_pixel(j, &sums, 0, PACKET, px, py);
        }
    } else {
        int per_packet = PACKET / o->spp;
        for (int px0 = 0; px0 < o->width; px0 += per_packet) {
            int pixels = o->width - px0 < per_packet ? o->width - px0 : per_packet;
            memset(&sums, 0, sizeof sums);
            for (int i = 0; i < pixels; i++) {
                rng r = rng_seed(o->seed, (uint64_t)py * (uint64_t)o->width + (uint64_t)(px0 + i));
                fill_lanes(j, &rh, i * o->spp, o->spp, px0 + i, py, lens_offset(j, px0 + i, py), 0, &r);
            }
            trace_lanes(j, &rh, pixels * o->spp, &sums, &counts);
            for (int i = 0; i < pixels; i++)
                finish_pixel(j, &sums, i * o->spp, o->spp, px0 + i, py);
        }
    }
    j->per_thread[thread].primary_rays += counts.primary_rays;
    j->per_thread[thread].shadow_rays += counts.shadow_rays;
    j->per_thread[thread].shadows.queries += counts.shadows.queries;
}

const char *truth_shadow_method_unavailable(int method)
{
    if (method == SHADOW_SLICEMAP_MODEL)
        return "slicemap-model needs a model's bake";
    if (method == SHADOW_VOXEL)
        return "voxel precomputes a model's shadow rays: the truth's own are march";
    return NULL;
}

shadow_request truth_shadow_request(const scene *s, const truth_options *o)
{
    /* A scene that asks for a method made from a model's data: its shadow rays are the reference. */
    int method =
        o->shadow_method < 0 && truth_shadow_method_unavailable(s->shadow_method) ? SHADOW_MARCH : o->shadow_method;
    return (shadow_request){method, o->shadow_res, o->threads, NULL};
}

int truth_render(const rt_scene *rt, const truth_options *o, image *out, truth_counts *counts, vx_err *e)
{
    if (o->spp < 1)
        return vx_fail(e, "--spp %d: expected at least 1 sample per pixel", o->spp);
    if (image_alloc(out, o->width, o->height, 3, e))
        return -1;
    int threads = parallel_threads(o->threads);
    /* Before the slicemap's clock and the frame's (parallel.h). */
    parallel_prestart(threads);
    truth_counts *per_thread = calloc((size_t)threads, sizeof(truth_counts));
    if (!per_thread) {
        image_free(out);
        return vx_fail(e, "out of memory for %d threads' ray counters", threads);
    }
    const scene *s = rt->scene;
    truth_job j = {.rt = rt, .o = o, .out = out, .per_thread = per_thread};
    truth_strata(o->spp, &j.strata_x, &j.strata_y);
    j.dof = (s->effects & EFFECT_DOF) != 0;
    j.shadows = (s->effects & EFFECT_SHADOWS) != 0;
    j.specular = (s->effects & EFFECT_SPECULAR) != 0;
    int m = j.strata_x * j.strata_y;
    j.lens_a = m / 2 + 1;
    while (gcd(j.lens_a, m) != 1)
        j.lens_a++;
    /* The slicemap (--shadows slicemap), built before the clock starts: its time is reported apart. */
    shadow_request sr = truth_shadow_request(s, o);
    shadow_stats sst;
    if (shadow_prepare(s, NULL, NULL, NULL, &sr, &j.maps, &sst, e)) {
        free(per_thread);
        image_free(out);
        return -1;
    }
    long f0 = vx_minor_faults();
    double t0 = now_seconds();
    parallel_for(o->height, threads, render_row, &j, o->progress ? "truth" : NULL);
    memset(counts, 0, sizeof *counts);
    counts->seconds = now_seconds() - t0;
    counts->page_faults = vx_minor_faults() - f0;
    counts->shadows = sst;
    shadow_release(j.maps);
    for (int t = 0; t < threads; t++) {
        counts->primary_rays += per_thread[t].primary_rays;
        counts->shadow_rays += per_thread[t].shadow_rays;
        counts->shadows.queries += per_thread[t].shadows.queries;
    }
    free(per_thread);
    return 0;
}
