/* `alpha`: the "averages" baseline (GigaVoxels-style). One mean colour, one mean normal and one
 * opacity per voxel, the fraction of the voxel's sample rays that hit inside it; front-to-back
 * alpha blending. */
#include "alpha_eval.h" /* the record and its evaluation (portable C, shared with OpenCL) */
#include "average_bake.h"

static void alpha_bake(const vx_voxel *v, const vx_sample *samples, int n, void *out)
{
    (void)v;
    alpha_record *r = out;
    int inside = 0;
    for (int i = 0; i < n; i++)
        inside += samples[i].kind == VX_SAMPLE_INSIDE_FRONT || samples[i].kind == VX_SAMPLE_INSIDE_BACK;
    r->opacity = n > 0 ? (float)inside / (float)n : 0.0f;
    /* Without front hits (back faces only) the colour stays 0: a dark occluder. */
    average_front_hits(samples, n, r->color, r->normal, &r->specular, &r->roughness);
}

const vx_model model_alpha = {
    .name = "alpha",
    .description = "averages: one colour, normal and opacity (hit fraction) per voxel; front-to-back alpha",
    .voxel_bytes = sizeof(alpha_record),
    .compositing = VX_COMPOSITE_ALPHA,
    .bake_voxel = alpha_bake,
    .opacity = alpha_eval_opacity,
    .shade = alpha_eval_shade,
    .cl_source = "alpha_eval.h",
    .cl_opacity = "alpha_eval_opacity",
    .cl_shade = "alpha_eval_shade",
};
