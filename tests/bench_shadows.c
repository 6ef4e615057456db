/* Benchmark (issue 18): the frame time of every model with precomputed shadows (slicemap-model:
 * the model's own opacity toward each light, built once per light) over its frame time with the
 * marched shadows (march), in the same run: renders of the two methods interleaved, every core,
 * wall seconds of the frame alone (the precomputation is built by the first slicemap-model render
 * and then served from the cache; its time and bytes are printed apart), medians of REPEATS each.
 * Goal: ratio <= 0.5 (shadows nearly free per frame). Also the triangles' slicemap for reference,
 * and both methods without the shading cache (--no-cache: every ray sample gathers its lights, so
 * shadows are most of a frame; with the cache a voxel's shadows are computed once per frame), and
 * the same frame with no shadows at all: the floor any shadow method can reach (no-shadow / march),
 * which says whether the goal is reachable on this machine.
 * usage: bench_shadows [SCENE] [RES] [SIZE] [REPEATS]   (default scenes/bunny.json 256 256 5) */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "bench.h"
#include "render.h"

static double frame(const scene *s, const voxel_grid *g, const vx_model *m, const void *records, int size,
                    int method, int cache, render_counts *counts)
{
    render_options o;
    render_default_options(&o);
    o.cache = cache;
    o.spp = m->cone ? 1 : 4; /* a cone model's natural setting: one cone covers the pixel */
    o.width = o.height = size;
    o.progress = 0;
    o.shadow_method = method;
    image img = {0};
    vx_err e;
    if (render_image(s, g, m, records, &o, &img, counts, &e)) {
        fprintf(stderr, "bench_shadows: %s: %s\n", m->name, e.msg);
        exit(1);
    }
    image_free(&img);
    return counts->seconds;
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : "scenes/bunny.json";
    int res = argc > 2 ? atoi(argv[2]) : 256, size = argc > 3 ? atoi(argv[3]) : 256;
    int repeats = argc > 4 ? atoi(argv[4]) : 5;
    if (repeats < 1 || repeats > 64 || res < 1 || size < 1) {
        fprintf(stderr, "usage: bench_shadows [SCENE] [RES] [SIZE] [REPEATS 1..64]\n");
        return 1;
    }
    scene s;
    vx_err e;
    if (scene_load(path, &s, &e)) {
        fprintf(stderr, "bench_shadows: %s\n", e.msg);
        return 1;
    }
    if (!(s.effects & EFFECT_SHADOWS)) {
        fprintf(stderr, "bench_shadows: %s declares no shadows\n", path);
        return 1;
    }
    printf("shadow methods on %s at %d^3, %dx%d, 4 spp (cone models: 1 cone), every core; frame wall seconds, "
           "median of %d interleaved (precomputation apart):\n",
           s.name, res, size, size, repeats);
    printf("  %-14s %10s %10s %10s %7s %10s %7s | %-8s %10s %10s %7s | %9s %8s %9s\n", "model", "march", "sm-model",
           "slicemap", "ratio", "none", "floor", "no-cache", "march", "sm-model", "ratio", "build (s)", "MiB",
           "queries");
    scene unshadowed = s; /* the floor: the same frame without shadows (read-only copy) */
    unshadowed.effects &= ~(unsigned)EFFECT_SHADOWS;
    int worst_ok = 1, floor_over = 1;
    for (const vx_model *const *mp = model_all(); *mp; mp++) {
        const vx_model *m = *mp;
        voxel_grid g;
        void *records;
        bake_options bo = {.rays = 150, .seed = 1, .threads = 0, .progress = 0};
        bake_counts bc;
        double gs;
        if (bake_scene(&s, m, res, &bo, &g, &records, &bc, &gs, &e)) {
            fprintf(stderr, "bench_shadows: %s: %s\n", m->name, e.msg);
            return 1;
        }
        shadow_cache_clear();
        double t[6][64];
        render_counts rc[6], first;
        frame(&s, &g, m, records, size, SHADOW_SLICEMAP_MODEL, 1, &first); /* builds the maps once */
        for (int i = 0; i < repeats; i++) {
            t[0][i] = frame(&s, &g, m, records, size, SHADOW_MARCH, 1, &rc[0]);
            t[1][i] = frame(&s, &g, m, records, size, SHADOW_SLICEMAP_MODEL, 1, &rc[1]);
            t[2][i] = frame(&s, &g, m, records, size, SHADOW_SLICEMAP, 1, &rc[2]);
            t[3][i] = frame(&s, &g, m, records, size, SHADOW_MARCH, 0, &rc[3]);
            t[4][i] = frame(&s, &g, m, records, size, SHADOW_SLICEMAP_MODEL, 0, &rc[4]);
            t[5][i] = frame(&unshadowed, &g, m, records, size, SHADOW_MARCH, 1, &rc[5]);
        }
        double march = bench_median(t[0], repeats), model = bench_median(t[1], repeats);
        double tri = bench_median(t[2], repeats);
        double march_nc = bench_median(t[3], repeats), model_nc = bench_median(t[4], repeats);
        double none = bench_median(t[5], repeats);
        printf("  %-14s %8.1fms %8.1fms %8.1fms %6.2fx %8.1fms %6.2fx | %-8s %8.1fms %8.1fms %6.2fx | %9.3f %8.2f "
               "%9.3g%s\n",
               m->name, 1e3 * march, 1e3 * model, 1e3 * tri, model / march, 1e3 * none, none / march, "",
               1e3 * march_nc, 1e3 * model_nc,
               model_nc / march_nc, first.shadows.build_seconds, (double)first.shadows.bytes / (1 << 20),
               (double)rc[1].shadows.queries, rc[1].shadows.cache_hit ? "" : "  (not cached!)");
        worst_ok &= model / march <= 0.5;
        floor_over &= none / march > 0.5;
        free(records);
        grid_free(&g);
        shadow_cache_clear();
    }
    printf("  slicemap-model / march <= 0.5 for every model (shading cache on, the default): %s\n",
           worst_ok ? "yes" : "no");
    if (floor_over)
        printf("  (unreachable here: without any shadows a frame already takes more than 0.5 x march for every "
               "model; the floor column is the best any shadow method can do)\n");
    scene_free(&s);
    return 0;
}
