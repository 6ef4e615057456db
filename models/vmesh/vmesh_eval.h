/* `vmesh` per-voxel evaluation entry points, with vx_model's opacity and shade signatures. Portable
 * C (also OpenCL C): this header and what it includes (vmesh_record.h, vmesh_opacity.h,
 * vmesh_shade.h, shading.h, vec.h, model.h) is the whole of the model's render-time code, so an
 * OpenCL build needs only this file as the model's source. */
#ifndef VX_VMESH_EVAL_H
#define VX_VMESH_EVAL_H

#include "vmesh_opacity.h"
#include "vmesh_shade.h"

VX_INLINE float vmesh_eval_opacity(VX_GLOBAL const void *record, const vx_query *q)
{
    return vmesh_opacity_along((VX_GLOBAL const vmesh_record *)record, q->ray_dir);
}

VX_INLINE void vmesh_eval_shade(VX_GLOBAL const void *record, const vx_query *q, vx_answer *a)
{
    a->radiance = vmesh_shade_record((VX_GLOBAL const vmesh_record *)record, q);
}

#endif
