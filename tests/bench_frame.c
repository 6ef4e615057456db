/* Frame-time benchmark (issue 15's figures), each a ratio against a reference measured in the same
 * run, medians of RUNS interleaved renders, the machine's load average printed beside them. A ratio is
 * the median of the rounds' own ratios (bench_paired_ratio: both times of a pair a second apart),
 * printed with their quartiles where a goal is checked, so that a verdict near its threshold can be
 * told from the rounds' spread:
 *  (a) every model's frame time, bunny 256^3, 256x256, 4 spp (heitz-neyret: one cone per pixel),
 *      against the 50 ms goal and over the truth's in the same rounds, and vmesh over alpha (goal
 *      <= 2); beside them, the per-voxel models' frames under Brito et al.'s protocol, shadows
 *      precomputed per voxel (--shadows voxel: march's image, its shadow rays cast before the
 *      frame, their time printed beside), and vmesh's over the paper's 37 ms (27 fps at 256^3 on an
 *      RTX 2080, shadows precomputed);
 *  (b) binary's frame time over the Embree truth's at 4 spp on the same image (goal <= 1);
 *  (c) frame time growth per doubling of the grid (128^3 -> ... -> MAX^3) for each model, the image
 *      fixed (goal <= 2 per doubling), RUNS rounds with each model's resolutions interleaved, each
 *      round's frame over the one below's in the same round; the growth grids are baked with
 *      GROWTH_RAYS rays per voxel, which changes the records a little, not the marching. Beside each,
 *      the growth of the model's evaluations (render_counts.model_evals: voxels shaded, or cone
 *      elements), which is what a model whose own work dominates grows with; and, in square brackets,
 *      the per-voxel models' growth with --shadows voxel (the frame without its shadow rays,
 *      precomputed before it);
 *  (d) binary's speed-up from 1 to 2 threads on city 256^3 (goal >= 1.8), the median of SPEEDUP_RUNS
 *      paired frames' ratios, and their quartiles (the shared host's second core is slower in some
 *      runs than in others: 1.75 to 1.95 between runs of an hour, each run's quartiles within 0.05);
 *  (e) `render --vox`'s grid at MAX^3: rebuilt from the file's level-0 cells (grid_build_sorted_cells)
 *      over voxelising the scene again (what it did before .vox version 4), and the bit array that
 *      the voxelisation needs and the rebuild does not;
 *  (f) (a) on the other scenes the issue is checked on, city and trees: every model's frame time at
 *      256^3, 256x256, 4 spp, and over the Embree truth's at 4 spp on the same image (medians of RUNS
 *      interleaved), the models baked together in one pass of the sampler; and the per-voxel models'
 *      frames with --shadows voxel, their precomputation beside.
 * usage: bench_frame [BUNNY_SCENE [CITY_SCENE [MAX_RES [TREES_SCENE]]]] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "bake_params.h"
#include "bench.h"
#include "grid_scene.h"
#include "parallel.h"
#include "render.h"
#include "scene_tris.h"
#include "truth.h"

#define RUNS 5
/* (d)'s pairs of frames: a ratio of two times, each swayed by the shared machine's other work,
 * needs more of them than a time does for a steady median (5 pairs gave 1.49 to 1.93 on the same
 * code within an hour); they cost about 1.5 s. */
#define SPEEDUP_RUNS 15
#define RAYS 150
#define GROWTH_RAYS 16
#define GROWTH_LEVELS 4 /* 128^3 to 1024^3 */

static int die(const char *what, const vx_err *e)
{
    fprintf(stderr, "bench_frame: %s: %s\n", what, e->msg);
    return 1;
}

static double load_average(void)
{
    double l = -1;
    FILE *f = fopen("/proc/loadavg", "r");
    if (f) {
        if (fscanf(f, "%lf", &l) != 1)
            l = -1;
        fclose(f);
    }
    return l;
}

typedef struct {
    const vx_model *m;
    voxel_grid g;
    void *records;
} baked;

static int bake(const scene *s, const vx_model *m, int res, int rays, baked *b)
{
    vx_err e;
    bake_options o = {.rays = rays, .seed = 1, .threads = 0, .progress = 0};
    bake_counts c;
    double gs;
    b->m = m;
    return bake_scene(s, m, res, &o, &b->g, &b->records, &c, &gs, &e) ? die("bake", &e) : 0;
}

static void unbake(baked *b)
{
    free(b->records);
    grid_free(&b->g);
}

static long last_page_faults; /* the last frame's page faults inside its clock (render_counts) */
static uint64_t last_evals;   /* the last frame's model evaluations (render_counts.model_evals) */

static double last_shadow_build; /* the last frame's shadow precomputation (render_counts.shadows) */

/* One frame of b at size x size, 4 spp, shadows by shadow_method (SHADOW_*; -1: the scene's); its
 * seconds (render_counts.seconds: the render alone). */
static double frame_shadows(const scene *s, const baked *b, int size, int threads, int shadow_method)
{
    render_options o;
    render_default_options(&o);
    o.width = o.height = size;
    o.threads = threads;
    o.progress = 0;
    o.shadow_method = shadow_method;
    image img;
    render_counts c;
    vx_err e;
    if (render_image(s, &b->g, b->m, b->records, &o, &img, &c, &e)) {
        die("render", &e);
        exit(1);
    }
    image_free(&img);
    last_page_faults = c.page_faults;
    last_evals = c.model_evals;
    last_shadow_build = c.shadows.build_seconds;
    return c.seconds;
}

static double frame(const scene *s, const baked *b, int size, int threads)
{
    return frame_shadows(s, b, size, threads, -1);
}

static double truth_frame(const rt_scene *rt, int size)
{
    truth_options o = {.spp = 4, .seed = 1, .threads = 0, .progress = 0, .width = size, .height = size, .shadow_method = -1};
    image img;
    truth_counts c;
    vx_err e;
    if (truth_render(rt, &o, &img, &c, &e)) {
        die("truth", &e);
        exit(1);
    }
    image_free(&img);
    return c.seconds;
}

/* (f): every model of scene s at 256^3 (baked in one pass) and its truth, interleaved. */
static int scene_frames(const scene *s)
{
    const vx_model *const *all = model_all();
    const vx_model *m[BAKE_MAX_MODELS];
    struct vx_bake_params params[BAKE_MAX_MODELS];
    int n = 0;
    for (; all[n] && n < BAKE_MAX_MODELS; n++) {
        m[n] = all[n];
        bake_params_defaults(m[n], &params[n]);
    }
    vx_err e;
    rt_scene rt;
    if (rt_build(&rt, s, &e))
        return die("embree", &e);
    bake_options o = {.rays = RAYS, .seed = 1, .threads = 0, .progress = 0};
    voxel_grid g;
    void *records[BAKE_MAX_MODELS];
    bake_counts c[BAKE_MAX_MODELS];
    double gs;
    if (bake_scene_models(s, n, m, params, 256, &o, &g, records, c, &gs, &e)) {
        rt_free(&rt);
        return die("bake", &e);
    }
    double t[BAKE_MAX_MODELS + 1][RUNS], pre[BAKE_MAX_MODELS][RUNS], pre_build[BAKE_MAX_MODELS][RUNS];
    for (int run = 0; run < RUNS; run++) {
        for (int k = 0; k < n; k++) {
            baked b = {m[k], g, records[k]};
            t[k][run] = frame(s, &b, 256, 0);
            if (!m[k]->cone) {
                pre[k][run] = frame_shadows(s, &b, 256, 0, SHADOW_VOXEL);
                pre_build[k][run] = last_shadow_build;
            }
        }
        t[n][run] = truth_frame(&rt, 256);
    }
    double over[BAKE_MAX_MODELS], lo, hi;
    for (int k = 0; k < n; k++)
        over[k] = bench_paired_ratio(t[k], t[n], RUNS, &lo, &hi); /* before the medians sort the times */
    double truth = bench_median(t[n], RUNS);
    printf("(f) frame time, %s 256^3, 256x256, 4 spp (medians of %d; truth at 4 spp %.1f ms; in brackets over the "
           "truth's, the median of the rounds' ratios):", s->name, RUNS, 1e3 * truth);
    for (int k = 0; k < n; k++)
        printf(" %s %.1f ms (x%.1f)", m[k]->name, 1e3 * bench_median(t[k], RUNS), over[k]);
    printf("\n    with shadows precomputed per voxel (--shadows voxel), frame (precomputation):");
    for (int k = 0; k < n; k++)
        if (!m[k]->cone)
            printf(" %s %.1f ms (%.1f)", m[k]->name, 1e3 * bench_median(pre[k], RUNS), 1e3 * bench_median(pre_build[k], RUNS));
    printf("\n");
    for (int k = 0; k < n; k++)
        free(records[k]);
    grid_free(&g);
    rt_free(&rt);
    return 0;
}

int main(int argc, char **argv)
{
    const char *bunny_path = argc > 1 ? argv[1] : "scenes/bunny.json";
    const char *city_path = argc > 2 ? argv[2] : "scenes/city.json";
    int max_res = argc > 3 ? atoi(argv[3]) : 1024;
    const char *trees_path = argc > 4 ? argv[4] : "scenes/trees.json";
    vx_err e;
    scene bunny, city;
    if (scene_load(bunny_path, &bunny, &e) || scene_load(city_path, &city, &e))
        return die("scene", &e);
    rt_scene rt;
    if (rt_build(&rt, &bunny, &e))
        return die("embree", &e);
    const vx_model *const *all = model_all();
    int n = 0;
    while (all[n])
        n++;
    if (n > 15) { /* med[] and the ratios below hold 15 models and the truth */
        fprintf(stderr, "bench_frame: %d models, at most 15\n", n);
        return 1;
    }
    printf("bench_frame: %d threads, load average %.2f at the start\n", parallel_threads(0), load_average());

    /* (a), (b) */
    baked *b = calloc((size_t)n, sizeof *b);
    for (int k = 0; k < n; k++)
        if (bake(&bunny, all[k], 256, RAYS, &b[k]))
            return 1;
    /* t: the scene's shadows (march); pre, pre_build: --shadows voxel's frame and precomputation
     * (per-voxel models only). */
    double *t = calloc((size_t)(n + 1) * RUNS, sizeof *t), med[16];
    double *pre = calloc((size_t)n * RUNS, sizeof *pre), *pre_build = calloc((size_t)n * RUNS, sizeof *pre_build);
    for (int run = 0; run < RUNS; run++) {
        for (int k = 0; k < n; k++) {
            t[k * RUNS + run] = frame(&bunny, &b[k], 256, 0);
            if (!all[k]->cone) {
                pre[k * RUNS + run] = frame_shadows(&bunny, &b[k], 256, 0, SHADOW_VOXEL);
                pre_build[k * RUNS + run] = last_shadow_build;
            }
        }
        t[n * RUNS + run] = truth_frame(&rt, 256);
    }
    /* Each model's frame over the truth's of the same round, before the medians sort the times. */
    double over_truth[16], over_lo[16], over_hi[16];
    for (int k = 0; k < n; k++)
        over_truth[k] = bench_paired_ratio(&t[k * RUNS], &t[n * RUNS], RUNS, &over_lo[k], &over_hi[k]);
    for (int k = 0; k <= n; k++)
        med[k] = bench_median(&t[k * RUNS], RUNS);
    /* Beside each time, its multiple of the truth's frame in the same rounds: the shared machine's
     * speed drifts by a fifth within minutes, which moves every time but hardly their ratios. */
    printf("(a) frame time, bunny 256^3, 256x256, 4 spp (medians of %d), goal <= 50 ms; in brackets over the "
           "truth's %.1f ms at 4 spp (the median of the %d rounds' ratios, each frame over the truth's of its "
           "round):\n", RUNS, 1e3 * med[n], RUNS);
    int alpha = -1, vmesh = -1, binary = -1;
    for (int k = 0; k < n; k++) {
        printf("    %-14s %8.1f ms  %-4s (x%.2f)\n", all[k]->name, 1e3 * med[k], med[k] <= 0.050 ? "ok" : "over",
               over_truth[k]);
        alpha = strcmp(all[k]->name, "alpha") ? alpha : k;
        vmesh = strcmp(all[k]->name, "vmesh") ? vmesh : k;
        binary = strcmp(all[k]->name, "binary") ? binary : k;
    }
    if (alpha >= 0 && vmesh >= 0)
        printf("    vmesh / alpha: %.2f (goal <= 2)\n", med[vmesh] / med[alpha]);
    printf("    the paper's protocol, shadows precomputed per voxel (--shadows voxel; the same images; medians of "
           "%d):\n", RUNS);
    for (int k = 0; k < n; k++)
        if (!all[k]->cone) {
            double f = bench_median(&pre[k * RUNS], RUNS), p = bench_median(&pre_build[k * RUNS], RUNS);
            printf("    %-14s %8.1f ms  %s (march's frame x%.2f); precomputed in %.1f ms\n", all[k]->name, 1e3 * f,
                   f <= 0.050 ? "ok" : "over", f / med[k], 1e3 * p);
        }
    if (vmesh >= 0)
        printf("    vmesh over the paper's 37 ms (RTX 2080, 27 fps at 256^3, shadows precomputed): %.2f\n",
               bench_median(&pre[vmesh * RUNS], RUNS) / 0.037);
    if (binary >= 0)
        printf("(b) binary / truth at 4 spp, same image: %.2f (goal <= 1; the median of %d same-round ratios, their "
               "quartiles %.2f-%.2f; the medians' ratio %.2f; truth %.1f ms)\n",
               over_truth[binary], RUNS, over_lo[binary], over_hi[binary], med[binary] / med[n], 1e3 * med[n]);
    for (int k = 0; k < n; k++)
        unbake(&b[k]);

    /* (c) */
    printf("(c) frame time growth per doubling, bunny 256x256 (grids baked with %d rays; %d rounds, the "
           "resolutions interleaved; a growth is the median of the rounds' own ratios, in parentheses their "
           "quartiles and the growth of the model's evaluations, in brackets the frame's with --shadows voxel):\n",
           GROWTH_RAYS, RUNS);
    for (int k = 0; k < n; k++) {
        /* Every resolution baked first, then their frames interleaved over RUNS rounds: a ratio of
         * two medians measured minutes apart swayed with the shared machine (3 frames a resolution,
         * one resolution after the other, once showed binary 256^3 -> 512^3 x2.78 where 9 rounds
         * of the same two grids gave x2.0). */
        baked g[GROWTH_LEVELS];
        int levels = 0;
        for (int res = 128; res <= max_res && levels < GROWTH_LEVELS; res *= 2, levels++)
            if (bake(&bunny, all[k], res, GROWTH_RAYS, &g[levels]))
                return 1;
        double march[GROWTH_LEVELS][RUNS], voxel[GROWTH_LEVELS][RUNS], evals[GROWTH_LEVELS];
        for (int run = 0; run < RUNS; run++)
            for (int l = 0; l < levels; l++) {
                march[l][run] = frame(&bunny, &g[l], 256, 0);
                if (run == 0)
                    evals[l] = (double)last_evals;
                if (!all[k]->cone)
                    voxel[l][run] = frame_shadows(&bunny, &g[l], 256, 0, SHADOW_VOXEL);
            }
        /* Each doubling's growth is the median of the rounds' own ratios (a resolution's frame over the
         * one below's, a second apart), taken before the median below sorts the lowest's times. */
        double grow[GROWTH_LEVELS], grow_lo[GROWTH_LEVELS], grow_hi[GROWTH_LEVELS], grow_pre[GROWTH_LEVELS];
        for (int l = 1; l < levels; l++) {
            double lo, hi;
            grow[l] = bench_paired_ratio(march[l], march[l - 1], RUNS, &grow_lo[l], &grow_hi[l]);
            grow_pre[l] = all[k]->cone ? 0 : bench_paired_ratio(voxel[l], voxel[l - 1], RUNS, &lo, &hi);
        }
        /* The lowest resolution's times, then each doubling's growth. */
        printf("    %-14s  128^3 %.1f ms (%.0fk evals)", all[k]->name, 1e3 * bench_median(march[0], RUNS),
               1e-3 * evals[0]);
        if (!all[k]->cone)
            printf(" [%.1f ms]", 1e3 * bench_median(voxel[0], RUNS));
        for (int l = 1; l < levels; l++) {
            printf("  %d^3 x%.2f%s (x%.2f-%.2f; evals x%.2f)", 128 << l, grow[l], grow[l] <= 2.0 ? "" : "!",
                   grow_lo[l], grow_hi[l], evals[l] / (evals[l - 1] > 0 ? evals[l - 1] : 1));
            if (!all[k]->cone)
                printf(" [x%.2f%s]", grow_pre[l], grow_pre[l] <= 2.0 ? "" : "!");
        }
        printf("\n");
        for (int l = 0; l < levels; l++)
            unbake(&g[l]);
    }

    /* (d) */
    const vx_model *bin = model_find("binary");
    baked c;
    if (bin && bake(&city, bin, 256, RAYS, &c) == 0) {
        double one[SPEEDUP_RUNS], two[SPEEDUP_RUNS];
        long faults = 0;
        for (int run = 0; run < SPEEDUP_RUNS; run++) {
            one[run] = frame(&city, &c, 256, 1);
            faults = last_page_faults > faults ? last_page_faults : faults;
            two[run] = frame(&city, &c, 256, 2);
            faults = last_page_faults > faults ? last_page_faults : faults;
        }
        double lo, hi, speedup = bench_paired_ratio(one, two, SPEEDUP_RUNS, &lo, &hi);
        printf("(d) binary, city 256^3, 256x256 (medians of %d pairs): 1 thread %.1f ms, 2 threads %.1f ms, speed-up "
               "%.2f (goal >= 1.8; the pairs' quartiles %.2f-%.2f); at most %ld page faults inside a frame's clock\n",
               SPEEDUP_RUNS, 1e3 * bench_median(one, SPEEDUP_RUNS), 1e3 * bench_median(two, SPEEDUP_RUNS), speedup,
               lo, hi, faults);
        unbake(&c);
    }
    /* (e) */
    voxel_grid full, from_cells;
    double lo[3], hi[3], vox[RUNS], cells[RUNS];
    scene_triangle_bounds(&bunny, lo, hi);
    for (int run = 0; run < RUNS; run++) {
        double t0 = now_seconds();
        if (grid_build_scene(&full, &bunny, max_res, NULL, NULL, &e))
            return die("grid", &e);
        double t1 = now_seconds();
        if (grid_build_sorted_cells(&from_cells, max_res, lo, hi, full.level[0].coords, full.level[0].count, &e))
            return die("grid from cells", &e);
        double t2 = now_seconds();
        vox[run] = t1 - t0;
        cells[run] = t2 - t1;
        if (run + 1 < RUNS)
            grid_free(&from_cells);
        grid_free(&full);
    }
    printf("(e) render --vox's grid, bunny %d^3 (%zu voxels): from the file's cells %.1f ms, voxelising %.1f ms, "
           "ratio %.3f; bit array avoided %.1f MB\n",
           max_res, grid_count(&from_cells, 0), 1e3 * bench_median(cells, RUNS), 1e3 * bench_median(vox, RUNS),
           bench_median(cells, RUNS) / bench_median(vox, RUNS), (double)max_res * max_res * max_res / 8 / 1e6);
    grid_free(&from_cells);
    /* (f) */
    scene trees;
    if (scene_load(trees_path, &trees, &e))
        return die("scene", &e);
    if (scene_frames(&city) || scene_frames(&trees))
        return 1;
    scene_free(&trees);
    printf("bench_frame: load average %.2f at the end\n", load_average());
    free(t);
    free(pre);
    free(pre_build);
    free(b);
    rt_free(&rt);
    scene_free(&bunny);
    scene_free(&city);
    return 0;
}
