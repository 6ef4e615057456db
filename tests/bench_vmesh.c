/* Benchmark of the `vmesh` model (Brito et al. 2023), each figure against a reference measured in
 * the same run (medians of 3):
 *  (a) bake time (grid + sampling + model) at 128^3 and 256^3, against our targets (2 s, 8 s), the
 *      paper's single-threaded 15 s / 66 s for the bunny, and the `alpha` baseline baked in the same
 *      run (the shared sampler's rays are the same; the difference is the model's own work);
 *  (b) render time over alpha's (128^3, 128x128, 4 spp, cache on and off), the ratio taken per run
 *      so both sides see the same machine state.
 * usage: bench_vmesh [SCENE] */
#include <stdio.h>
#include <stdlib.h>

#include "bench.h"
#include "bake.h"
#include "parallel.h"
#include "render.h"

#define RUNS 3
#define RAYS 150

static int die(const char *what, const vx_err *e)
{
    fprintf(stderr, "bench_vmesh: %s: %s\n", what, e->msg);
    return 1;
}

/* Grid + bake of one model (what `voxlab bake` spends after loading); *records kept when asked. */
static int bake_once(const rt_scene *rt, const vx_model *m, int res, int threads, double *seconds, voxel_grid *keep_g,
                     void **keep_records)
{
    vx_err e;
    voxel_grid g;
    double t0 = now_seconds();
    if (grid_build(&g, &rt->scene->mesh, res, &e))
        return die("grid", &e);
    bake_options o = {.rays = RAYS, .seed = 1, .threads = threads, .progress = 0};
    void *records = NULL;
    bake_counts c;
    if (bake_run(rt, &g, m, &o, &records, &c, &e))
        return die("bake", &e);
    *seconds = now_seconds() - t0;
    if (keep_g) {
        *keep_g = g;
        *keep_records = records;
    } else {
        free(records);
        grid_free(&g);
    }
    return 0;
}

/* (a) */
static int bench_bake(const rt_scene *rt, const vx_model *vm, const vx_model *alpha, int threads, int res,
                      double target, double paper)
{
    double v[RUNS], a[RUNS], ratio[RUNS];
    for (int run = 0; run < RUNS; run++) {
        if (bake_once(rt, vm, res, threads, &v[run], NULL, NULL) || bake_once(rt, alpha, res, threads, &a[run], NULL, NULL))
            return 1;
        ratio[run] = v[run] / a[run];
    }
    double t = bench_median(v, RUNS);
    printf("vmesh  %-8s %d^3 bake %.2f s (alpha %.2f s; vmesh/alpha %.2f), %zu B/voxel, %d threads; time/target %.2f "
           "(target %.0f s, <= 1 meets it); paper (single-threaded, %.0f s)/ours %.1fx (median of %d)\n",
           rt->scene->name, res, t, bench_median(a, RUNS), bench_median(ratio, RUNS), vm->record.bytes, threads, t / target, target,
           paper, paper / t, RUNS);
    return 0;
}

static int render_once(const scene *s, const voxel_grid *g, const vx_model *m, const void *records, int threads,
                       int cache, double *seconds)
{
    render_options o;
    render_default_options(&o);
    o.width = o.height = 128;
    o.spp = 4;
    o.threads = threads;
    o.progress = 0;
    o.cache = cache;
    image img = {0};
    render_counts rc;
    vx_err e;
    if (render_image(s, g, m, records, &o, &img, &rc, &e))
        return die("render", &e);
    image_free(&img);
    *seconds = rc.seconds;
    return 0;
}

/* (b) */
static int bench_render(const rt_scene *rt, const vx_model *vm, const vx_model *alpha, int threads, int res)
{
    voxel_grid gv, ga;
    void *rv = NULL, *ra = NULL;
    double unused;
    if (bake_once(rt, vm, res, threads, &unused, &gv, &rv) || bake_once(rt, alpha, res, threads, &unused, &ga, &ra))
        return 1;
    for (int cache = 1; cache >= 0; cache--) {
        double v[RUNS], a[RUNS], ratio[RUNS];
        for (int run = 0; run < RUNS; run++) {
            if (render_once(rt->scene, &gv, vm, rv, threads, cache, &v[run]) ||
                render_once(rt->scene, &ga, alpha, ra, threads, cache, &a[run]))
                return 1;
            ratio[run] = v[run] / a[run];
        }
        printf("vmesh  %-8s %d^3 render 128x128 4 spp, cache %s: vmesh %.1f ms, alpha %.1f ms; vmesh/alpha %.2f "
               "(median of %d)\n",
               rt->scene->name, res, cache ? "on " : "off", 1e3 * bench_median(v, RUNS), 1e3 * bench_median(a, RUNS),
               bench_median(ratio, RUNS), RUNS);
    }
    free(rv);
    free(ra);
    grid_free(&gv);
    grid_free(&ga);
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
    const vx_model *vm = model_find("vmesh"), *alpha = model_find("alpha");
    if (!vm || !alpha) {
        fprintf(stderr, "bench_vmesh: models vmesh and alpha must be registered\n");
        return 1;
    }
    int threads = parallel_threads(0);
    /* Brito et al. (Table 2) report 15 s (128^3) and 66 s (256^3) for the bunny on one thread. */
    int rc = bench_bake(&rt, vm, alpha, threads, 128, 2.0, 15.0) || bench_bake(&rt, vm, alpha, threads, 256, 8.0, 66.0) ||
             bench_render(&rt, vm, alpha, threads, 128);
    rt_free(&rt);
    scene_free(&s);
    return rc;
}
