/* `vmesh`: virtual mesh + opacity subgrid (Brito, Poulin, Teichrieb 2023). Per voxel: an SGGX-fitted
 * octahedron whose eight faces hold a colour and 1-3 normals or three extremal normals of a
 * distribution, and a 3x3x3 subgrid of opacities projected as disks for a directional opacity;
 * front-to-back alpha compositing. Record: vmesh_record.h; bake: vmesh_bake.c and the files it
 * calls; per-voxel evaluation (portable C, also the OpenCL backend's source): vmesh_eval.h; moving
 * records (transform, combine): vmesh_move.c. */
#include "vmesh_bake.h"
#include "vmesh_eval.h"

#include <stdio.h>

/* Squared length of a quantised vector, in units of 127^2. */
static int qlen2(const signed char *q) { return q[0] * q[0] + q[1] * q[1] + q[2] * q[2]; }

/* What the bake (vmesh_bake.c) can write: signed bytes from a clamp to [-1, 1] (never -128); unit
 * axes (each component off by at most 1/254, so a length within 1 +- 0.01), or none at all when no
 * sample hit a front face; face normals unit or absent ((0,0,0)); faces without data hold neither
 * normals nor colour, and only faces with data may be distributions. */
static int vmesh_validate(const void *record, const vx_record_context *c, char *why, size_t why_size)
{
    (void)c;
    const vmesh_record *r = record;
    const int unit_lo = 115 * 115, unit_hi = 140 * 140; /* |v| in about [0.9, 1.1] x 127 */
    const signed char *bytes = &r->axis[0][0];
    for (int i = 0; i < 9; i++)
        if (bytes[i] == -128) {
            snprintf(why, why_size, "axis[%d][%d]: -128 (expected -127..127)", i / 3, i % 3);
            return -1;
        }
    for (int f = 0; f < VMESH_FACES; f++)
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 3; j++)
                if (r->normal[f][k][j] == -128) {
                    snprintf(why, why_size, "normal[%d][%d][%d]: -128 (expected -127..127)", f, k, j);
                    return -1;
                }
    if (r->distribution & ~r->faces) {
        snprintf(why, why_size, "distribution: 0x%02x marks faces without data (faces 0x%02x)", r->distribution,
                 r->faces);
        return -1;
    }
    for (int k = 0; k < 3; k++) {
        int l2 = qlen2(r->axis[k]);
        if (r->faces ? (l2 < unit_lo || l2 > unit_hi) : l2 != 0) {
            snprintf(why, why_size, "axis[%d]: length %g (expected %s)", k, sqrt((double)l2) / 127.0,
                     r->faces ? "1: a unit eigenvector" : "0: no face holds data");
            return -1;
        }
    }
    for (int f = 0; f < VMESH_FACES; f++) {
        int has = (r->faces >> f) & 1;
        for (int k = 0; k < 3; k++) {
            int l2 = qlen2(r->normal[f][k]);
            if (has ? (l2 != 0 && (l2 < unit_lo || l2 > unit_hi)) : l2 != 0) {
                snprintf(why, why_size, "normal[%d][%d]: length %g (expected %s)", f, k, sqrt((double)l2) / 127.0,
                         has ? "1, or 0 for no normal" : "0: the face holds no data");
                return -1;
            }
        }
        if (!has && (r->color[f][0] | r->color[f][1] | r->color[f][2])) {
            snprintf(why, why_size, "color[%d]: non-zero on a face without data (faces 0x%02x)", f, r->faces);
            return -1;
        }
    }
    return 0;
}

static const vx_voxel_eval vmesh_eval = {
    .compositing = VX_COMPOSITE_ALPHA,
    .source = "vmesh_eval.h",
    .opacity = VX_PORTABLE(vmesh_eval_opacity),
    .shade = VX_PORTABLE(vmesh_eval_shade),
    .opacity_by_direction = 1, /* vmesh_eval_opacity reads the record and q->ray_dir only */
    /* A view (vmesh_opacity.h: the window, the 27 projected centres, the normaliser and the ratios)
     * is most of a primary evaluation; with a direction per 4 x 4 pixels the voxels seen through them
     * share one, kept by vmesh_view_of. */
    .view_tile_pixels = 4,
};

const vx_model model_vmesh = {
    .abi_version = VX_MODEL_ABI_VERSION,
    .name = "vmesh",
    .description = "virtual mesh + 3x3x3 opacity subgrid (Brito et al. 2023): SGGX octahedron faces with "
                   "colours and normals, directional opacity from projected sub-cells; front-to-back alpha",
    .record = {.bytes = sizeof(vmesh_record), .layout_version = 1},
    .bake_voxel = vmesh_bake_voxel,
    .validate_record = vmesh_validate,
    .voxel = &vmesh_eval,
    .transform = vmesh_transform, /* vmesh_move.c */
    .combine = vmesh_combine,
};
