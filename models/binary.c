/* `binary`: 0/1 opacity (the Carmack-style baseline). A voxel is opaque when any of its sample rays
 * hit inside it on a front face; its colour and normal are the means over those hits; nearest
 * lookup, first-hit compositing. */
#include "binary_eval.h" /* the record and its evaluation (portable C, shared with OpenCL) */

static void binary_bake(const vx_voxel *v, const vx_sample *samples, int n, void *out)
{
    (void)v;
    binary_record *r = out;
    int hits = 0;
    vec3 c = v3(0, 0, 0), nrm = v3(0, 0, 0);
    float spec = 0, rough = 0;
    for (int i = 0; i < n; i++)
        if (samples[i].kind == VX_SAMPLE_INSIDE_FRONT) {
            hits++;
            c = v3_add(c, samples[i].albedo);
            nrm = v3_add(nrm, samples[i].normal);
            spec += samples[i].specular;
            rough += samples[i].roughness;
        }
    r->opaque = hits > 0;
    if (!hits)
        return;
    float inv = 1.0f / (float)hits;
    c = v3_scale(c, inv);
    nrm = v3_scale(nrm, inv);
    r->color[0] = c.x, r->color[1] = c.y, r->color[2] = c.z;
    r->normal[0] = nrm.x, r->normal[1] = nrm.y, r->normal[2] = nrm.z;
    r->specular = spec * inv;
    r->roughness = rough * inv;
}

const vx_model model_binary = {
    .name = "binary",
    .description = "0/1 opacity: opaque where any sample hit a front face; mean colour and normal; first hit",
    .voxel_bytes = sizeof(binary_record),
    .compositing = VX_COMPOSITE_FIRST_HIT,
    .bake_voxel = binary_bake,
    .opacity = binary_eval_opacity,
    .shade = binary_eval_shade,
    .cl_source = "binary_eval.h",
    .cl_opacity = "binary_eval_opacity",
    .cl_shade = "binary_eval_shade",
};
