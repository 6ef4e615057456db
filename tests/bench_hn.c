/* Benchmark: heitz-neyret render time over alpha's on the same scene, grid and image, measured in
 * the same run (one thread: microseconds per pixel per core). Times are the process's CPU time
 * (other jobs on the machine stretch wall time, not CPU time), runs of the two models interleaved,
 * median of 5 each. alpha renders as
 * it does by default (4 jittered rays per pixel, shading cache on); heitz-neyret with one cone per
 * pixel (--spp 1, its natural setting: the cone covers the pixel). Then depth of field: the
 * scene's camera with a thin lens (aperture 2 % of the focus distance), heitz-neyret's time with
 * the widened cones over its focused time.
 * usage: bench_hn [SCENE] [RES] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench.h"
#include "bake.h"
#include "parallel.h"
#include "render.h"

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* CPU seconds of one render. */
static double render_once(const scene *s, const voxel_grid *g, const vx_model *m, const void *records, int spp,
                          render_counts *counts)
{
    render_options o;
    render_default_options(&o);
    o.spp = spp;
    o.width = s->width;
    o.height = s->height;
    o.threads = 1;
    o.progress = 0;
    image img = {0};
    vx_err e;
    double t0 = cpu_seconds();
    if (render_image(s, g, m, records, &o, &img, counts, &e)) {
        fprintf(stderr, "bench_hn: %s\n", e.msg);
        exit(1);
    }
    double t = cpu_seconds() - t0;
    image_free(&img);
    return t;
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : "scenes/bunny.json";
    int res = argc > 2 ? atoi(argv[2]) : 256;
    scene s;
    vx_err e;
    if (scene_load(path, &s, &e)) {
        fprintf(stderr, "bench_hn: %s\n", e.msg);
        return 1;
    }
    const char *names[2] = {"alpha", "heitz-neyret"};
    int spp[2] = {4, 1};
    double secs[2];
    render_counts rc[2];
    voxel_grid g[2];
    void *records[2];
    for (int k = 0; k < 2; k++) {
        const vx_model *m = model_find(names[k]);
        bake_options bo = {.rays = 150, .seed = 1, .threads = 0, .progress = 0};
        bake_counts bc;
        double gs;
        if (!m || bake_scene(&s, m, res, &bo, &g[k], &records[k], &bc, &gs, &e)) {
            fprintf(stderr, "bench_hn: %s: %s\n", names[k], m ? e.msg : "model missing");
            return 1;
        }
    }
    double t[2][5];
    for (int i = 0; i < 5; i++)
        for (int k = 0; k < 2; k++)
            t[k][i] = render_once(&s, &g[k], model_find(names[k]), records[k], spp[k], &rc[k]);
    for (int k = 0; k < 2; k++)
        secs[k] = bench_median(t[k], 5);
    double pixels = (double)s.width * s.height;
    printf("heitz-neyret render on %s at %d^3, %dx%d, 1 thread, CPU seconds (median of 5, interleaved):\n", s.name, res, s.width, s.height);
    printf("  alpha (4 rays/pixel, cache)   %.3f s  %.2f us/pixel/core\n", secs[0], 1e6 * secs[0] / pixels);
    printf("  heitz-neyret (1 cone/pixel)   %.3f s  %.2f us/pixel/core  (%.1f cone elements and %.2f light cones "
           "per pixel)\n",
           secs[1], 1e6 * secs[1] / pixels, (double)rc[1].voxel_visits / pixels, (double)rc[1].shadow_rays / pixels);
    printf("  heitz-neyret / alpha          %.2fx  (target <= 1.5x)\n", secs[1] / secs[0]);
    /* Depth of field: the same camera with a thin lens. */
    float focus = s.camera.focus_distance;
    s.effects |= EFFECT_DOF;
    s.camera.aperture_radius = 0.02f * focus;
    render_counts rd;
    double td[5];
    for (int i = 0; i < 5; i++)
        td[i] = render_once(&s, &g[1], model_find("heitz-neyret"), records[1], 1, &rd);
    double dof = bench_median(td, 5);
    printf("  with depth of field (aperture %.3f, focus %.2f): %.3f s, %.2fx the focused render "
           "(%.1f cone elements per pixel)\n",
           s.camera.aperture_radius, focus, dof, dof / secs[1], (double)rd.voxel_visits / pixels);
    for (int k = 0; k < 2; k++) {
        free(records[k]);
        grid_free(&g[k]);
    }
    scene_free(&s);
    return 0;
}
