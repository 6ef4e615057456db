/* `vmesh` shading from the virtual octahedron (Brito et al. 2023, §3.3 "Projected Area Sampling",
 * §4). Portable C (also OpenCL C): no libc beyond <math.h>, no allocation, no random numbers.
 *
 * Seen from w (toward the viewer), every face that holds data and faces w is sampled over its
 * projection; a sample is kept when its normal faces w too ("only samples visible to the camera are
 * used"), and weighs its share of the face's projected area. The voxel's radiance is the weighted
 * mean of Lambert (plus the Beckmann lobe under "specular") of the kept samples with the face's
 * colour, the lights taken at the voxel's centre as the tracer gives them.
 *  - Distribution faces: 40 stratified points of the projected triangle; barycentric coordinates
 *    are preserved by a parallel projection, so the points are fixed barycentric triples (8x5 strata
 *    centres of the unit square, Shirley's square-to-triangle warp) and the normal is the
 *    normalised barycentric blend of the three extremal normals.
 *  - 1-3 distinct normals: a point takes the normal of its nearest vertex holding one. Measured by
 *    the largest barycentric coordinate among those vertices, each of the m of them owns exactly
 *    1/m of the triangle whatever the view, so each normal is evaluated once with 1/m of the area.
 *  - A face's flat octahedron side tilts by up to atan(0.1) = 5.7 degrees from its normals (the
 *    projected areas are clamped to >= 0.1), so a surface seen at 84-90 degrees would have no
 *    front-facing face left and turn black at every silhouette. Only when the front-facing faces
 *    keep no sample, the back-facing faces' front-facing samples are used (weighted by |area|).
 *    Seen from behind a single-sided surface nothing faces the viewer: radiance 0, a dark
 *    occluder, as the paper's Figure 10 (bottom) shows and the ground truth does. */
#ifndef VX_VMESH_SHADE_H
#define VX_VMESH_SHADE_H

#include "shading.h"
#include "vmesh_record.h"

#define VMESH_DIST_SAMPLES 40
/* A sample is "front-facing" when n.w exceeds this, not merely 0: a normal that close to grazing has
 * no projected area to speak of, and below 1e-6 shading.h's Smith term clamps its cosine while the
 * lobe's 1 / (4 n.l n.v) does not, so the specular value would blow up (1e5 and more). */
#define VMESH_MIN_COS 1e-4f

/* Barycentric coordinates of stratified sample i of VMESH_DIST_SAMPLES (8 x 5 strata). */
VX_INLINE vec3 vmesh_stratified_barycentric(int i)
{
    float u = ((float)(i % 8) + 0.5f) * (1.0f / 8.0f), v = ((float)(i / 8) + 0.5f) * (1.0f / 5.0f);
    float su = sqrtf(u);
    float b0 = 1.0f - su, b1 = v * su;
    return v3(b0, b1, 1.0f - b0 - b1);
}

/* Outgoing radiance toward q->to_viewer of a surface point with normal n (unit, facing the viewer). */
VX_INLINE vec3 vmesh_point_radiance(vec3 n, vec3 albedo, float f0, float alpha, const vx_query *q)
{
    vec3 sum = v3(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < q->light_count; i++) {
        float cos_l = v3_dot(n, q->to_light[i]);
        if (!(cos_l > 0.0f))
            continue;
        vec3 f = v3_scale(albedo, 1.0f / VX_PI);
        if (q->effects & VX_EFFECT_SPECULAR) {
            float s = shading_specular_brdf(n, q->to_viewer, q->to_light[i], f0, alpha);
            f = v3_add(f, v3(s, s, s));
        }
        sum = v3_add(sum, v3_mul(v3_scale(f, cos_l), q->irradiance[i]));
    }
    return sum;
}

VX_INLINE vec3 vmesh_shade_record(VX_GLOBAL const vmesh_record *r, const vx_query *q)
{
    vec3 zero = v3(0.0f, 0.0f, 0.0f);
    if (!r->faces)
        return zero;
    vmesh_octahedron o = vmesh_decode_octahedron(r);
    vec3 w = q->to_viewer;
    float f0 = vmesh_decode_unorm(r->specular), alpha = vmesh_decode_roughness(r->roughness);
    vec3 sum = zero;
    float weight = 0.0f;
    /* pass 0: faces facing the viewer (the paper); pass 1: the others, only if pass 0 kept nothing. */
    for (int pass = 0; pass < 2 && !(weight > 0.0f); pass++)
        for (int f = 0; f < VMESH_FACES; f++) {
            if (!((r->faces >> f) & 1))
                continue;
            float area = vmesh_face_projected_area(&o, f, w);
            if (pass == 0 ? !(area > 0.0f) : area > 0.0f)
                continue;
            area = vx_fmaxf(fabsf(area), 1e-12f); /* an edge-on face still has its samples */
            vec3 albedo = v3(vmesh_decode_unorm(r->color[f][0]), vmesh_decode_unorm(r->color[f][1]),
                             vmesh_decode_unorm(r->color[f][2]));
            vec3 n[3];
            int held = 0; /* vertices holding a normal (a stored unit vector is never (0,0,0)) */
            for (int k = 0; k < 3; k++) {
                vec3 raw = vmesh_decode_vec(r->normal[f][k]);
                held += raw.x != 0.0f || raw.y != 0.0f || raw.z != 0.0f;
                n[k] = v3_normalize_or(raw, v3(0.0f, 0.0f, 0.0f));
            }
            if ((r->distribution >> f) & 1) {
                float share = area / (float)VMESH_DIST_SAMPLES;
                for (int i = 0; i < VMESH_DIST_SAMPLES; i++) {
                    vec3 bc = vmesh_stratified_barycentric(i);
                    vec3 m = v3_add(v3_add(v3_scale(n[0], bc.x), v3_scale(n[1], bc.y)), v3_scale(n[2], bc.z));
                    m = v3_normalize_or(m, n[0]);
                    if (!(v3_dot(m, w) > VMESH_MIN_COS))
                        continue;
                    sum = v3_madd(sum, vmesh_point_radiance(m, albedo, f0, alpha, q), share);
                    weight += share;
                }
            } else if (held > 0) {
                float share = area / (float)held;
                for (int k = 0; k < 3; k++) { /* an empty vertex has n = 0 and fails the test */
                    if (!(v3_dot(n[k], w) > VMESH_MIN_COS))
                        continue;
                    sum = v3_madd(sum, vmesh_point_radiance(n[k], albedo, f0, alpha, q), share);
                    weight += share;
                }
            }
        }
    return weight > 0.0f ? v3_scale(sum, 1.0f / weight) : zero;
}

#endif
