/* `alpha`: the per-voxel record and its evaluation. Portable C: models/alpha/alpha.c uses these
 * functions as the model's opacity and shade, and the OpenCL backend compiles this same file as
 * OpenCL C (model_alpha.cl_source), so the two backends cannot drift apart. */
#ifndef VX_ALPHA_EVAL_H
#define VX_ALPHA_EVAL_H

#include "average_shading.h"

typedef struct {
    float color[3];
    float normal[3]; /* mean of the front-facing hit normals (length <= 1) */
    float opacity;
    float specular, roughness;
    unsigned int double_sided; /* most front hits were on a double-sided material */
} alpha_record;

VX_INLINE float alpha_eval_opacity(VX_GLOBAL const void *record, const vx_query *q)
{
    (void)q;
    return ((VX_GLOBAL const alpha_record *)record)->opacity;
}

VX_INLINE void alpha_eval_shade(VX_GLOBAL const void *record, const vx_query *q, vx_answer *a)
{
    VX_GLOBAL const alpha_record *r = (VX_GLOBAL const alpha_record *)record;
    a->radiance = average_shading(v3(r->color[0], r->color[1], r->color[2]),
                                  v3(r->normal[0], r->normal[1], r->normal[2]), r->specular, r->roughness, r->double_sided, q);
}

#endif
