/* `alpha`: the "averages" baseline (GigaVoxels-style). One mean colour, one mean normal and one
 * opacity per voxel, the fraction of the voxel's sample rays that hit inside it; front-to-back
 * alpha blending. */
#include "alpha_eval.h" /* the record and its evaluation (portable C, shared with OpenCL) */

static void alpha_bake(const vx_voxel *v, const vx_sample *samples, int n, void *out)
{
    (void)v;
    alpha_record *r = out;
    int inside = 0, front = 0;
    vec3 c = v3(0, 0, 0), nrm = v3(0, 0, 0);
    float spec = 0, rough = 0;
    for (int i = 0; i < n; i++) {
        int k = samples[i].kind;
        inside += k == VX_SAMPLE_INSIDE_FRONT || k == VX_SAMPLE_INSIDE_BACK;
        if (k == VX_SAMPLE_INSIDE_FRONT) {
            front++;
            c = v3_add(c, samples[i].albedo);
            nrm = v3_add(nrm, samples[i].normal);
            spec += samples[i].specular;
            rough += samples[i].roughness;
        }
    }
    r->opacity = n > 0 ? (float)inside / (float)n : 0.0f;
    if (!front)
        return; /* back faces only: a dark occluder */
    float inv = 1.0f / (float)front;
    c = v3_scale(c, inv);
    nrm = v3_scale(nrm, inv);
    r->color[0] = c.x, r->color[1] = c.y, r->color[2] = c.z;
    r->normal[0] = nrm.x, r->normal[1] = nrm.y, r->normal[2] = nrm.z;
    r->specular = spec * inv;
    r->roughness = rough * inv;
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
