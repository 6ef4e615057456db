/* Benchmark of the bake sampler and the render's shading cache, each figure printed against a
 * reference measured in the same run (medians):
 *  (a) bake rays/s over raw Embree rays/s: the raw side traces the very same sample rays (generated
 *      by bake_generate_rays beforehand, outside the timing) from the voxel's entry with
 *      rtcIntersect16 only, in packets of 16 on the same threads: what a whole-scene closest-hit
 *      sampler would pay for its rays alone. The bake side is bake_run with the `alpha` model
 *      (own-triangle lists and their ray tests, tracer/bake/bake.h).
 *  (b) bake time at 128^3 and 256^3 (alpha, 150 rays) against our targets and the times Brito et
 *      al. report for their single-threaded baker.
 *  (c) render time with the shading cache on over off (alpha and binary, 128^3, 128x128, 4 spp),
 *      and the MSE the cache costs (cached vs uncached image);
 *  (d) every registered model baked in one pass of the sampler (bake_run_models) over the same models
 *      baked one by one, 128^3 (medians of 3 interleaved); and each model's bake_seconds as the shared
 *      pass reports it (the samples' part plus its own calls) over what its own bake reports.
 * usage: bench_bake [SCENE] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "bake.h"
#include "bake_params.h"
#include "metrics.h"
#include "parallel.h"
#include "render.h"

#define RAYS 150
#define PACKET 16
/* Same work granularity as bake_run, so both sides are scheduled alike. */
#define VOXELS_PER_ITEM 32

/* One pre-generated ray: only what rtcIntersect16 needs (28 bytes instead of a 76-byte vx_sample,
 * which keeps 4 million rays of a 128^3 grid near 120 MB). */
typedef struct {
    float ox, oy, oz, dx, dy, dz, tnear;
} raw_ray;

typedef struct {
    const rt_scene *rt;
    const voxel_grid *g;
    raw_ray *rays;        /* RAYS per voxel, by dense index */
    vx_sample **scratch;  /* per thread, for generation */
    float slack;
    uint64_t hits[64][8]; /* per thread, padded to a cache line so threads do not share one */
} raw_job;

static void generate_item(void *p, int64_t item, int thread)
{
    raw_job *j = p;
    size_t count = grid_count(j->g, 0);
    vx_sample *s = j->scratch[thread];
    for (size_t i = (size_t)item * VOXELS_PER_ITEM; i < (size_t)(item + 1) * VOXELS_PER_ITEM && i < count; i++) {
        bake_generate_rays(j->rt, j->g, i, 1, RAYS, s);
        raw_ray *r = &j->rays[i * RAYS];
        for (int k = 0; k < RAYS; k++) {
            /* tnear at the voxel's entry (less the slack): the whole-scene query from the voxel on. */
            r[k] = (raw_ray){s[k].origin.x, s[k].origin.y, s[k].origin.z, s[k].dir.x,
                             s[k].dir.y,    s[k].dir.z,    fmaxf(0.0f, s[k].t_entry - j->slack)};
        }
    }
}

/* A reference for the bake's speed: each voxel's rays through the whole scene's BVH, in packets of 16. */
static void raw_item(void *p, int64_t item, int thread)
{
    raw_job *j = p;
    size_t count = grid_count(j->g, 0);
    uint64_t hits = 0;
    for (size_t i = (size_t)item * VOXELS_PER_ITEM; i < (size_t)(item + 1) * VOXELS_PER_ITEM && i < count; i++) {
        const raw_ray *r = &j->rays[i * RAYS];
        for (int first = 0; first < RAYS; first += PACKET) {
            struct RTCRayHit16 rh;
            int valid[PACKET] __attribute__((aligned(64)));
            for (int k = 0; k < PACKET; k++) {
                const raw_ray *q = &r[first + k < RAYS ? first + k : first];
                valid[k] = first + k < RAYS ? -1 : 0;
                rt_packet_rayhit(&rh, k, v3(q->ox, q->oy, q->oz), v3(q->dx, q->dy, q->dz), q->tnear, INFINITY);
            }
            struct RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx); /* incoherent rays */
            rtcIntersect16(valid, j->rt->bvh, &ctx, &rh);
            for (int k = 0; k < PACKET; k++)
                hits += valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
        }
    }
    j->hits[thread][0] += hits;
}

static int die(const char *what, const vx_err *e)
{
    fprintf(stderr, "bench_bake: %s: %s\n", what, e->msg);
    return 1;
}

/* (a) */
static int bench_rays(const rt_scene *rt, const vx_model *alpha, int threads, int res)
{
    enum { RUNS = 3 };
    vx_err e;
    voxel_grid g;
    if (grid_build(&g, &rt->scene->mesh, res, &e))
        return die("grid", &e);
    size_t voxels = grid_count(&g, 0);
    raw_job *j = calloc(1, sizeof *j);
    vx_sample **scratch = calloc((size_t)threads, sizeof *scratch);
    raw_ray *rays = malloc(voxels * RAYS * sizeof(raw_ray));
    int ok = j && scratch && rays;
    for (int t = 0; ok && t < threads; t++)
        ok = (scratch[t] = malloc(RAYS * sizeof(vx_sample))) != NULL;
    if (!ok || threads > 64) {
        fprintf(stderr, "bench_bake: out of memory for %zu rays (or more than 64 threads)\n", voxels * RAYS);
        return 1;
    }
    *j = (raw_job){.rt = rt, .g = &g, .rays = rays, .scratch = scratch,
                   /* bake_trace's slack (tracer/bake/bake.c). */
                   .slack = 1e-4f * g.voxel_size + rt->epsilon * 0.1f};
    int64_t items = (int64_t)((voxels + VOXELS_PER_ITEM - 1) / VOXELS_PER_ITEM);
    /* Timed once, for information only: it tells how much of the gap is ray generation. */
    double g0 = now_seconds();
    parallel_for(items, threads, generate_item, j, NULL);
    double gen_rate = (double)voxels * RAYS / (now_seconds() - g0);

    double raw[RUNS], ours[RUNS], ratio[RUNS];
    uint64_t raw_rays = (uint64_t)voxels * RAYS;
    for (int run = 0; run < RUNS; run++) {
        double t0 = now_seconds();
        parallel_for(items, threads, raw_item, j, NULL);
        raw[run] = (double)raw_rays / (now_seconds() - t0);

        bake_options o = {.rays = RAYS, .seed = 1, .threads = threads, .progress = 0};
        void *records = NULL;
        bake_counts c;
        if (bake_run(rt, &g, alpha, &o, &records, &c, &e))
            return die("bake", &e);
        free(records);
        ours[run] = (double)c.rays / c.seconds;
        ratio[run] = ours[run] / raw[run]; /* per run: both halves saw the same machine state */
    }
    uint64_t hits = 0;
    for (int t = 0; t < threads; t++)
        hits += j->hits[t][0];
    printf("bake   %-8s %d^3 %zu voxels x %d rays, %d threads: bake %.2f Mrays/s; raw rtcIntersect16 %.2f Mrays/s "
           "(%.0f%% hit); generation alone %.1f Mrays/s\n",
           rt->scene->name, res, voxels, RAYS, threads, bench_median(ours, RUNS) / 1e6, bench_median(raw, RUNS) / 1e6,
           100.0 * (double)hits / ((double)raw_rays * RUNS), gen_rate / 1e6);
    printf("bake   ratio bake/raw-Embree rays/s: %.2f (target >= 0.5; median of %d)\n", bench_median(ratio, RUNS), RUNS);
    for (int t = 0; t < threads; t++)
        free(scratch[t]);
    free(scratch);
    free(rays);
    free(j);
    grid_free(&g);
    return 0;
}

/* (b): grid build + sampling + the model's finish pass, what `voxlab bake` spends after loading. */
static int bench_bake_time(const rt_scene *rt, const vx_model *alpha, int threads, int res, double target,
                           double paper)
{
    enum { RUNS = 3 };
    double total[RUNS], grid_s[RUNS], bake_s[RUNS];
    size_t voxels = 0;
    for (int run = 0; run < RUNS; run++) {
        vx_err e;
        voxel_grid g;
        double t0 = now_seconds();
        if (grid_build(&g, &rt->scene->mesh, res, &e))
            return die("grid", &e);
        grid_s[run] = now_seconds() - t0;
        bake_options o = {.rays = RAYS, .seed = 1, .threads = threads, .progress = 0};
        void *records = NULL;
        bake_counts c;
        if (bake_run(rt, &g, alpha, &o, &records, &c, &e))
            return die("bake", &e);
        bake_s[run] = c.seconds + c.finish_seconds;
        total[run] = grid_s[run] + bake_s[run];
        voxels = grid_count(&g, 0);
        free(records);
        grid_free(&g);
    }
    double t = bench_median(total, RUNS);
    printf("bake   %-8s %d^3 alpha %d rays, %zu voxels, %d threads: %.2f s (grid %.3f s + sampling %.2f s; median of %d)\n",
           rt->scene->name, res, RAYS, voxels, threads, t, bench_median(grid_s, RUNS), bench_median(bake_s, RUNS), RUNS);
    printf("bake   %d^3 time/target: %.2f (target %.0f s, <= 1 meets it); paper (single-threaded, %.0f s)/ours: %.1fx\n",
           res, t / target, target, paper, paper / t);
    return 0;
}

/* (d) */
static int bench_shared(const rt_scene *rt, int threads, int res)
{
    enum { RUNS = 3 };
    const vx_model *m[BAKE_MAX_MODELS];
    struct vx_bake_params params[BAKE_MAX_MODELS];
    int count = 0;
    for (const vx_model *const *all = model_all(); *all && count < BAKE_MAX_MODELS; all++) {
        m[count] = *all;
        bake_params_defaults(m[count], &params[count]);
        count++;
    }
    vx_err e;
    voxel_grid g;
    if (grid_build(&g, &rt->scene->mesh, res, &e))
        return die("grid", &e);
    bake_options o = {.rays = RAYS, .seed = 1, .threads = threads, .progress = 0};
    double one_by_one[RUNS], shared[RUNS], ratio[RUNS];
    /* Each model's bake_seconds from the shared pass (its estimate) over its own bake's. */
    double estimate[BAKE_MAX_MODELS][RUNS];
    for (int run = 0; run < RUNS; run++) {
        void *records[BAKE_MAX_MODELS];
        bake_counts c[BAKE_MAX_MODELS], alone[BAKE_MAX_MODELS];
        double t0 = now_seconds();
        for (int k = 0; k < count; k++) {
            if (bake_run_models(rt, &g, 1, &m[k], &params[k], &o, &records[k], &alone[k], &e))
                return die("bake", &e);
            free(records[k]);
        }
        double t1 = now_seconds();
        if (bake_run_models(rt, &g, count, m, params, &o, records, c, &e))
            return die("shared bake", &e);
        double t2 = now_seconds();
        for (int k = 0; k < count; k++) {
            free(records[k]);
            estimate[k][run] = (c[k].seconds + c[k].finish_seconds) / (alone[k].seconds + alone[k].finish_seconds);
        }
        one_by_one[run] = t1 - t0;
        shared[run] = t2 - t1;
        ratio[run] = shared[run] / one_by_one[run];
    }
    printf("bake   %-8s %d^3, %d models, %d rays, %d threads: one pass %.2f s, one by one %.2f s, ratio %.2f "
           "(median of %d)\n",
           rt->scene->name, res, count, RAYS, threads, bench_median(shared, RUNS), bench_median(one_by_one, RUNS),
           bench_median(ratio, RUNS), RUNS);
    printf("bake   each model's bake_seconds from the shared pass over its own bake's (goal: near 1):");
    for (int k = 0; k < count; k++)
        printf(" %s %.2f", m[k]->name, bench_median(estimate[k], RUNS));
    printf("\n");
    grid_free(&g);
    return 0;
}

/* (c) */
static int bench_cache(const rt_scene *rt, const char *model_name, int threads, int res)
{
    enum { RUNS = 5 };
    const scene *s = rt->scene;
    const vx_model *m = model_find(model_name);
    vx_err e;
    voxel_grid g;
    if (!m) {
        fprintf(stderr, "bench_bake: no model %s\n", model_name);
        return 1;
    }
    if (grid_build(&g, &s->mesh, res, &e))
        return die("grid", &e);
    bake_options bo = {.rays = RAYS, .seed = 1, .threads = threads, .progress = 0};
    void *records = NULL;
    bake_counts bc;
    if (bake_run(rt, &g, m, &bo, &records, &bc, &e))
        return die("bake", &e);
    double secs[2][RUNS];
    image img[2] = {{0}, {0}};
    uint64_t hits = 0;
    for (int run = 0; run < RUNS; run++) {
        for (int cache = 1; cache >= 0; cache--) { /* alternate, so drift hits both alike */
            render_options o;
            render_default_options(&o);
            o.width = o.height = 128;
            o.spp = 4;
            o.threads = threads;
            o.progress = 0;
            o.cache = cache;
            image_free(&img[cache]);
            render_counts rc;
            if (render_image(s, &g, m, records, &o, &img[cache], &rc, &e))
                return die("render", &e);
            secs[cache][run] = rc.seconds;
            if (cache)
                hits = rc.cache_hits;
        }
    }
    image_metrics mt;
    if (metrics_compare(&img[1], &img[0], &mt, &e))
        return die("compare", &e);
    double on = bench_median(secs[1], RUNS), off = bench_median(secs[0], RUNS);
    printf("render %-8s %d^3 %-6s 128x128 4 spp: cache on %.1f ms, off %.1f ms (%llu cache hits); "
           "ratio on/off %.2f (speedup %.2fx; median of %d); cached vs uncached MSE %.3g, SSIM %.4f\n",
           s->name, res, m->name, 1e3 * on, 1e3 * off, (unsigned long long)hits, on / off, off / on, RUNS, mt.mse,
           mt.ssim);
    image_free(&img[0]);
    image_free(&img[1]);
    free(records);
    grid_free(&g);
    return 0;
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : "scenes/bunny.json";
    vx_err e;
    scene s;
    rt_scene rt;
    if (scene_load(path, &s, &e) || rt_build(&rt, &s, &e))
        return die(path, &e);
    const vx_model *alpha = model_find("alpha");
    if (!alpha) {
        fprintf(stderr, "bench_bake: no model alpha\n");
        return 1;
    }
    int threads = parallel_threads(0);
    /* Brito et al. report 15 s (128^3) and 66 s (256^3) for the bunny on one thread. */
    int rc = bench_rays(&rt, alpha, threads, 128) || bench_bake_time(&rt, alpha, threads, 128, 2.0, 15.0) ||
             bench_bake_time(&rt, alpha, threads, 256, 8.0, 66.0) || bench_cache(&rt, "alpha", threads, 128) ||
             bench_cache(&rt, "binary", threads, 128) || bench_shared(&rt, threads, 128);
    rt_free(&rt);
    scene_free(&s);
    return rc;
}
