/* `binary`: 0/1 opacity (the Carmack-style baseline). A voxel is opaque when any of its sample rays
 * hit inside it on a front face; its colour and normal are the means over those hits; nearest
 * lookup, first-hit compositing. */
#include "binary_eval.h" /* the record and its evaluation (portable C, shared with OpenCL) */
#include "average_bake.h"
#include "average_move.h"
#include "average_validate.h"

static void binary_bake(const vx_voxel *v, const vx_sample *samples, int n, void *out)
{
    (void)v;
    binary_record *r = out;
    r->opaque = average_front_hits(samples, n, r->color, r->normal, &r->specular, &r->roughness, &r->double_sided) > 0;
}

static int binary_validate(const void *record, const vx_record_context *c, char *why, size_t why_size)
{
    (void)c;
    const binary_record *r = record;
    if (r->opaque > 1u) {
        snprintf(why, why_size, "opaque: %u (expected 0 or 1)", r->opaque);
        return -1;
    }
    return average_validate_fields(r->color, r->normal, r->specular, r->roughness, r->double_sided, why, why_size);
}

static void binary_transform(const void *in, const float R[9], void *out)
{
    binary_record r = *(const binary_record *)in;
    if (!average_is_identity(R))
        average_rotate(R, r.normal, r.normal);
    *(binary_record *)out = r;
}

/* Opaque when opaque parts cover at least half the voxel: a surface split over two layers by a
 * half-voxel offset stays one layer thick on average (each layer gets half), and two records put
 * whole into one voxel (a moving object over a static one) stay opaque. */
static void binary_combine(const vx_record_part *parts, int n, float voxel_size, void *out)
{
    (void)voxel_size; /* nothing in the record is a length */
    if (n == 1 && parts[0].weight == 1.0f) {
        *(binary_record *)out = *(const binary_record *)parts[0].record;
        return;
    }
    binary_record r;
    memset(&r, 0, sizeof r);
    average_view v[n > 0 ? n : 1];
    double cover = 0;
    for (int i = 0; i < n; i++) {
        const binary_record *a = parts[i].record;
        v[i] = (average_view){a->color, a->normal, a->specular, a->roughness, a->double_sided,
                              a->opaque ? parts[i].weight : 0.0f};
        cover += v[i].weight;
    }
    r.opaque = cover >= 0.5;
    if (r.opaque)
        average_combine_fields(v, n, r.color, r.normal, &r.specular, &r.roughness, &r.double_sided);
    *(binary_record *)out = r;
}

static const vx_voxel_eval binary_eval = {
    .compositing = VX_COMPOSITE_FIRST_HIT,
    .source = "binary_eval.h",
    .opacity = VX_PORTABLE(binary_eval_opacity),
    .shade = VX_PORTABLE(binary_eval_shade),
    .opacity_by_direction = 1, /* binary_eval_opacity reads the record and q->ray_dir only */
};

const vx_model model_binary = {
    .abi_version = VX_MODEL_ABI_VERSION,
    .name = "binary",
    .description = "0/1 opacity: opaque where any sample hit a front face; mean colour and normal; first hit",
    .record = {.bytes = sizeof(binary_record), .layout_version = 1},
    .bake_voxel = binary_bake,
    .validate_record = binary_validate,
    .voxel = &binary_eval,
    .transform = binary_transform,
    .combine = binary_combine,
};
