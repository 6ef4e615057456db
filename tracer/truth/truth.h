/* Ground truth: the scene's triangles rendered with Embree, box-filtered over each pixel with
 * stratified jittered samples (strata.h). Computes exactly the declared effects. */
#ifndef VX_TRUTH_H
#define VX_TRUTH_H

#include <stdint.h>

#include "image.h"
#include "rt.h"
#include "shadow_set.h"

typedef struct {
    int spp; /* samples per pixel, default 1024 */
    int width, height;
    uint64_t seed;
    int threads; /* 0 = every core */
    int progress; /* show progress on stderr when it is a terminal */
    int shadow_method; /* SHADOW_MARCH (Embree shadow rays) or SHADOW_SLICEMAP; -1: the scene's */
    int shadow_res;    /* slicemap columns per side (0: the default) */
} truth_options;

typedef struct {
    double seconds;
    uint64_t primary_rays, shadow_rays;
    long page_faults;     /* the process's minor page faults during `seconds` (render_counts.page_faults' twin) */
    shadow_stats shadows; /* the shadow method, its precomputation (outside `seconds`), its queries */
} truth_counts;

int truth_render(const rt_scene *rt, const truth_options *o, image *out, truth_counts *counts, vx_err *e);

/* Why the truth cannot compute shadows by `method` (SHADOW_*), or NULL when it can: it has no model,
 * so a method made from a model's data (slicemap-model, voxel) is not its own. `voxlab truth` and the
 * Python API refuse such a method with this reason; a scene that declares one gets the truth's shadow
 * rays (march), the reference. */
const char *truth_shadow_method_unavailable(int method);
/* The shadows truth_render asks for under o (the scene's method, or march where the scene's needs a
 * model), for the checks a caller makes before any work (shadow_check_lights). */
shadow_request truth_shadow_request(const scene *s, const truth_options *o);

#endif
