/* Ground truth: the scene's triangles rendered with Embree, box-filtered over each pixel with
 * stratified jittered samples. Computes exactly the declared effects. */
#ifndef VX_TRUTH_H
#define VX_TRUTH_H

#include <stdint.h>

#include "image.h"
#include "rt.h"

typedef struct {
    int spp; /* samples per pixel, default 1024 */
    int width, height;
    uint64_t seed;
    int threads; /* 0 = every core */
    int progress; /* show progress on stderr when it is a terminal */
} truth_options;

typedef struct {
    double seconds;
    uint64_t primary_rays, shadow_rays;
} truth_counts;

int truth_render(const rt_scene *rt, const truth_options *o, image *out, truth_counts *counts, vx_err *e);

/* The sample position in [0,1)^2 of sample i of n in a pixel: jittered in a sx * sy grid of strata
 * (sx = floor(sqrt(n)), sy = n / sx); samples beyond sx * sy are uniformly random. */
void truth_stratified_sample(int i, int n, float r1, float r2, float *x, float *y);
/* The same in two steps, for loops over many samples: the strata counts, then sample i. */
void truth_strata(int n, int *sx, int *sy);
void truth_strata_sample(int i, int sx, int sy, float r1, float r2, float *x, float *y);

#endif
