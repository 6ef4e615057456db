/* `make bench` (issue 17): the moving objects' voxel transformation against re-baking them, per
 * object and per frame, in the same run: bench_dynamic SCENE RES MODEL... For an animated scene
 * (scenes/dynamic.py), each model's moving objects are baked once; then at frames spread over the
 * animation the median time of transforming their records into the world lattice (split8, which
 * costs more than nearest) is set against the median time of re-baking them as posed (grid + bake of
 * the moving triangles alone: the paper's "standard voxelization"). Goal (the issue): <= 0.05.
 * Without MODEL arguments: every registered model with transform/combine. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "animation.h"
#include "bench.h"
#include "dynamic.h"

#define RUNS 5

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: bench_dynamic SCENE RES [MODEL...]\n");
        return 2;
    }
    int res = atoi(argv[2]);
    scene s;
    vx_err e;
    if (scene_load(argv[1], &s, &e) || !s.anim || s.anim->count == 0) {
        fprintf(stderr, "bench_dynamic: %s\n", s.anim ? e.msg : "the scene has no moving object");
        return 1;
    }
    int objects = s.anim->count, first = s.anim->first, last = s.anim->last;
    bake_options bo = {.rays = 150, .seed = 1};
    const vx_model *const *all = model_all();
    int count = argc > 3 ? argc - 3 : 0;
    for (const vx_model *const *p = all; argc == 3 && *p; p++)
        count++;
    for (int a = 0; a < count; a++) {
        const vx_model *m = argc > 3 ? model_find(argv[3 + a]) : all[a];
        if (argc == 3 && !m->transform)
            continue;
        if (!m || !m->transform) {
            fprintf(stderr, "bench_dynamic: %s: not a model with transform\n", argv[3 + a]);
            return 1;
        }
        scene_set_frame(&s, first, &e);
        dyn_scene d;
        if (dyn_prepare(&d, &s, m, res, &bo, &e)) {
            fprintf(stderr, "bench_dynamic: %s\n", e.msg);
            return 1;
        }
        int *moving = malloc((size_t)objects * sizeof *moving);
        for (int i = 0; i < objects; i++)
            moving[i] = 1 + i;
        double tr[RUNS], rb[RUNS];
        size_t voxels = 0;
        for (int r = 0; r < RUNS; r++) {
            int f = first + (int)((long long)(last - first) * (2 * r + 1) / (2 * RUNS));
            scene_set_frame(&s, f, &e);
            voxel_grid g;
            void *rec;
            dyn_counts c;
            if (dyn_frame_parts(&d, &s, f, DYN_SPLIT8, moving, objects, &g, &rec, &c, &e) ||
                dyn_rebake_moving(&s, m, res, &bo, &rb[r], &e)) {
                fprintf(stderr, "bench_dynamic: %s\n", e.msg);
                return 1;
            }
            tr[r] = c.transform_seconds + c.grid_seconds;
            voxels = c.voxels;
            free(rec);
            grid_free(&g);
        }
        double t = bench_median(tr, RUNS), b = bench_median(rb, RUNS);
        printf("dynamic %-7s %3d objects %d^3: transform (split8) %.3f ms/object, re-bake %.3f ms/object "
               "(%zu voxels moved): ratio %.4f (goal <= 0.05)\n",
               m->name, objects, res, 1e3 * t / objects, 1e3 * b / objects, voxels, t / b);
        free(moving);
        dyn_free(&d);
    }
    scene_free(&s);
    return 0;
}
