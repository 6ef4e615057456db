/* Benchmark: ground-truth rays per second over raw Embree rtcIntersect16 rays per second, on the
 * same scene, camera, image size and sample count, measured in the same run (median of 5 each).
 * usage: bench_truth [SCENE] [SPP] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "bench.h"
#include "camera.h"
#include "parallel.h"
#include "rng.h"
#include "strata.h"
#include "truth.h"

typedef struct {
    const rt_scene *rt;
    int width, height, spp;
    uint64_t *hits;
} raw_job;

/* The bare minimum a renderer must do: generate the same camera rays and intersect them. */
static void raw_row(void *p, int64_t row, int thread)
{
    raw_job *j = p;
    const scene *s = j->rt->scene;
    int py = (int)row;
    uint64_t hits = 0;
    int strata_x, strata_y;
    truth_strata(j->spp, &strata_x, &strata_y);
    for (int px = 0; px < j->width; px++) {
        rng r = rng_seed(1, (uint64_t)py * (uint64_t)j->width + (uint64_t)px);
        for (int first = 0; first < j->spp; first += 16) {
            struct RTCRayHit16 rh;
            int valid[16] __attribute__((aligned(64)));
            for (int k = 0; k < 16; k++) {
                float sx, sy;
                float r1 = rng_float(&r), r2 = rng_float(&r);
                truth_strata_sample(first + k, strata_x, strata_y, r1, r2, &sx, &sy);
                vec3 o, d;
                camera_ray(&s->camera, j->width, j->height, (float)px + sx, (float)py + sy, 0, 0, 0, &o, &d);
                valid[k] = first + k < j->spp ? -1 : 0;
                rt_packet_rayhit(&rh, k, o, d, 0.0f, INFINITY);
            }
            struct RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            rtcIntersect16(valid, j->rt->bvh, &ctx, &rh);
            for (int k = 0; k < 16; k++)
                hits += valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
        }
    }
    j->hits[thread] += hits;
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : "scenes/bunny.json";
    int spp = argc > 2 ? atoi(argv[2]) : 64;
    vx_err e;
    scene s;
    rt_scene rt;
    if (scene_load(path, &s, &e) || rt_build(&rt, &s, &e)) {
        fprintf(stderr, "bench_truth: %s\n", e.msg);
        return 1;
    }
    int threads = parallel_threads(0);
    enum { RUNS = 5 };
    double raw[RUNS], ours[RUNS], ours_primary[RUNS];
    for (int run = 0; run < RUNS; run++) {
        uint64_t hits[64] = {0};
        raw_job j = {&rt, s.width, s.height, spp, hits};
        double t0 = now_seconds();
        parallel_for(s.height, threads, raw_row, &j, NULL);
        raw[run] = (double)s.width * s.height * spp / (now_seconds() - t0);

        truth_options o = {.spp = spp, .width = s.width, .height = s.height, .seed = 1, .threads = threads, .shadow_method = -1};
        image img = {0};
        truth_counts c;
        if (truth_render(&rt, &o, &img, &c, &e)) {
            fprintf(stderr, "bench_truth: %s\n", e.msg);
            return 1;
        }
        image_free(&img);
        ours[run] = (double)(c.primary_rays + c.shadow_rays) / c.seconds;
        ours_primary[run] = (double)c.primary_rays / c.seconds;
    }
    printf("truth  %-10s %dx%d %4d spp %d threads: truth %.1f Mrays/s (primary+shadow), %.1f Mrays/s primary; "
           "raw rtcIntersect16 %.1f Mrays/s\n",
           s.name, s.width, s.height, spp, threads, bench_median(ours, RUNS) / 1e6, bench_median(ours_primary, RUNS) / 1e6,
           bench_median(raw, RUNS) / 1e6);
    printf("truth  ratio truth/raw-Embree rays/s: %.2f (target >= 0.7; medians of %d)\n", bench_median(ours, RUNS) / bench_median(raw, RUNS),
           RUNS);
    rt_free(&rt);
    scene_free(&s);
    return 0;
}
