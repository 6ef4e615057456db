/* `vmesh`: virtual mesh + opacity subgrid (Brito, Poulin, Teichrieb 2023). Per voxel: an SGGX-fitted
 * octahedron whose eight faces hold a colour and 1-3 normals or three extremal normals of a
 * distribution, and a 3x3x3 subgrid of opacities projected as disks for a directional opacity;
 * front-to-back alpha compositing. Record: vmesh_record.h; bake: vmesh_bake.c and the files it
 * calls; per-voxel evaluation (portable C, also the OpenCL backend's source): vmesh_eval.h. */
#include "vmesh_bake.h"
#include "vmesh_eval.h"

const vx_model model_vmesh = {
    .name = "vmesh",
    .description = "virtual mesh + 3x3x3 opacity subgrid (Brito et al. 2023): SGGX octahedron faces with "
                   "colours and normals, directional opacity from projected sub-cells; front-to-back alpha",
    .voxel_bytes = sizeof(vmesh_record),
    .compositing = VX_COMPOSITE_ALPHA,
    .uses_levels = 0,
    .march = VX_MARCH_VOXELS,
    .bake_voxel = vmesh_bake_voxel,
    .opacity = vmesh_eval_opacity,
    .shade = vmesh_eval_shade,
    .cl_source = "vmesh_eval.h",
    .cl_opacity = "vmesh_eval_opacity",
    .cl_shade = "vmesh_eval_shade",
};
