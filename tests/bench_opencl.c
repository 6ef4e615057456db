/* Benchmark of `render --backend opencl` against the C backend, for every registered model: render
 * time (median of RUNS, alternating backends so that drift hits both alike) of OpenCL over C on the
 * same baked grid, same options (default 4 spp, or one cone per pixel for a cone marcher; cache on)
 * and the same cores; the OpenCL time excludes the kernel compile, which is reported apart (the
 * first call's, and a cached one's), and its set-up (buffers, uploads, clears), as the C time
 * excludes the C backend's (both are `setup_seconds`). The CPU time of both (process CPU time over the render; for
 * OpenCL over the kernel, PoCL's worker threads being in the process) is printed too: on a shared
 * machine it is steadier than the wall clock, which depends on what else runs. The images are
 * compared too (max per-pixel difference) so that a fast but wrong kernel shows. For a per-voxel
 * model, OpenCL's frame with the shadows precomputed per voxel (--shadows voxel, Brito et al.'s
 * protocol: the paper's 37 ms exclude their shadow precomputation) is printed beside, with the
 * precomputation's time.
 * Models that cannot run on OpenCL are listed with the backend's reason.
 * usage: bench_opencl [SCENE [RES [SIZE [MODEL]]]]   (defaults: scenes/bunny.json 128 256, every model;
 * one MODEL makes a quicker run when only its figure is wanted) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench.h"
#include "bake.h"
#include "opencl_backend.h"
#include "parallel.h"
#include "render.h"

#define RUNS 5

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double max_difference(const image *a, const image *b)
{
    double d = 0;
    size_t n = (size_t)a->width * (size_t)a->height * (size_t)a->channels;
    for (size_t i = 0; i < n; i++)
        d = fmax(d, fabs((double)a->data[i] - (double)b->data[i]));
    return d;
}

static int bench_model(const scene *s, const vx_model *m, int res, int size)
{
    vx_err e;
    voxel_grid g;
    void *records = NULL;
    bake_counts bc;
    double grid_seconds;
    bake_options bo = {.rays = 150, .seed = 1, .progress = 0};
    if (bake_scene(s, m, res, &bo, &g, &records, &bc, &grid_seconds, &e)) {
        fprintf(stderr, "bench_opencl: bake %s: %s\n", m->name, e.msg);
        return 1;
    }
    render_options o;
    render_default_options(&o);
    o.width = o.height = size;
    o.progress = 0;
    double c_s[RUNS], cl_s[RUNS], kernel_s[RUNS], c_cpu[RUNS], cl_cpu[RUNS], first_compile = 0, compile = 0;
    backend_counts device = {0};
    image img_c = {0}, img_cl = {0};
    int rc = 0;
    for (int run = 0; run < RUNS && !rc; run++) {
        render_counts cnt;
        backend_counts oc;
        image_free(&img_c);
        image_free(&img_cl);
        double cpu0 = cpu_seconds();
        if (render_image(s, &g, m, records, &o, &img_c, &cnt, &e)) {
            fprintf(stderr, "bench_opencl: C render of %s: %s\n", m->name, e.msg);
            rc = 1;
            break;
        }
        c_s[run] = cnt.seconds;
        c_cpu[run] = cpu_seconds() - cpu0;
        if (render_image_opencl(s, &g, m, records, &o, &img_cl, &cnt, &oc, &e)) {
            printf("opencl %-8s %d^3 %-12s not run on OpenCL: %s\n", s->name, res, m->name, e.msg);
            goto done;
        }
        cl_s[run] = cnt.seconds;
        kernel_s[run] = oc.kernel_seconds;
        cl_cpu[run] = oc.kernel_cpu_seconds;
        device = oc;
        if (run == 0)
            first_compile = oc.compile_seconds;
        else
            compile = oc.compile_seconds;
    }
    if (!rc) {
        double c = bench_median(c_s, RUNS), cl = bench_median(cl_s, RUNS);
        double ccpu = bench_median(c_cpu, RUNS), clcpu = bench_median(cl_cpu, RUNS);
        /* A cone-marching model traces one cone per pixel whatever the spp option says. */
        char rays[32];
        if (m->cone != NULL)
            snprintf(rays, sizeof rays, "1 cone/pixel");
        else
            snprintf(rays, sizeof rays, "%d spp", o.spp);
        printf("opencl %-8s %d^3 %-12s %dx%d %s: C %.1f ms, OpenCL %.1f ms (kernel %.1f); CPU time C %.1f ms, "
               "OpenCL kernel %.1f ms; compile %.2f s first, %.2f s cached; max |OpenCL - C| %.2g\n",
               s->name, res, m->name, size, size, rays, 1e3 * c, 1e3 * cl, 1e3 * bench_median(kernel_s, RUNS), 1e3 * ccpu,
               1e3 * clcpu, first_compile, compile, max_difference(&img_c, &img_cl));
        printf("opencl %-8s %-12s ratio OpenCL/C render time: %.2f (target <= 1; median of %d); CPU time "
               "ratio %.2f; device %s, %u compute units, %s launch, C on %d threads\n",
               s->name, m->name, cl / c, RUNS, clcpu / ccpu, device.device, device.compute_units,
               device.wide_launch ? "wide" : "tiled", parallel_threads(0));
        /* Brito et al. 2023 render 256^3 at 27 fps (37 ms a frame) on an RTX 2080: on a GPU the
         * OpenCL frame is set against that figure (issue 15). */
        if (device.wide_launch)
            printf("opencl %-8s %-12s %d^3 on %s: %.2f ms a frame, %.3f of the paper's 37 ms (RTX 2080)\n", s->name,
                   m->name, res, device.device, 1e3 * cl, 1e3 * cl / 37.0);
        if (!m->cone) {
            render_options pre = o;
            pre.shadow_method = SHADOW_VOXEL;
            double f[RUNS], build[RUNS];
            for (int run = 0; run < RUNS; run++) {
                render_counts cnt;
                backend_counts oc;
                image_free(&img_cl);
                if (render_image_opencl(s, &g, m, records, &pre, &img_cl, &cnt, &oc, &e)) {
                    printf("opencl %-8s %-12s --shadows voxel not run: %s\n", s->name, m->name, e.msg);
                    goto done;
                }
                f[run] = cnt.seconds;
                build[run] = cnt.shadows.build_seconds;
            }
            printf("opencl %-8s %-12s %d^3 with shadows precomputed per voxel (--shadows voxel, the paper's "
                   "protocol): %.2f ms a frame (x%.2f of march's), %.3f of the paper's 37 ms; precomputed in %.1f ms "
                   "on the CPU\n",
                   s->name, m->name, res, 1e3 * bench_median(f, RUNS), bench_median(f, RUNS) / cl,
                   1e3 * bench_median(f, RUNS) / 37.0, 1e3 * bench_median(build, RUNS));
        }
    }
done:
    image_free(&img_c);
    image_free(&img_cl);
    free(records);
    grid_free(&g);
    return rc;
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : "scenes/bunny.json";
    int res = argc > 2 ? atoi(argv[2]) : 128, size = argc > 3 ? atoi(argv[3]) : 256;
    const char *only = argc > 4 ? argv[4] : NULL;
    vx_err e;
    scene s;
    if (res < 1 || size < 1) {
        fprintf(stderr, "usage: bench_opencl [SCENE [RES [SIZE [MODEL]]]]\n");
        return 1;
    }
    if (scene_load(path, &s, &e)) {
        fprintf(stderr, "bench_opencl: %s\n", e.msg);
        return 1;
    }
    int rc = 0;
    for (const vx_model *const *m = model_all(); *m && !rc; m++)
        if (!only || !strcmp(only, (*m)->name))
            rc = bench_model(&s, *m, res, size);
    scene_free(&s);
    return rc;
}
