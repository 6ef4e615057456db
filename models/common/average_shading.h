/* Shading of a voxel summarised by averages (one colour, one mean normal): shared by the `binary`
 * and `alpha` baselines. Portable C (OpenCL C too).
 *
 * The mean of unit normals is shorter than 1 when they disagree; its length says how much of the
 * voxel's surface shares one orientation. Lambert is blended by that length between the mean
 * normal's cosine and 1/4, the mean of max(0, n.l) over normals uniform on the sphere: opposite or
 * spread normals (length 0) shade like a fuzzy ball instead of dividing by zero.
 *
 * Sides: the mean normal is the surfaces' own front-side orientation. A double-sided material is
 * lit from whichever side the viewer sees (the normal turned toward the viewer, as the ground truth
 * does); a single-sided one is not turned: seen from behind, its voxel shows the side its samples
 * saw, lit as that side is (the paper's averages baseline carries no side information to do
 * better, and turning it would light back faces that the truth leaves dark). */
#ifndef VX_AVERAGE_SHADING_H
#define VX_AVERAGE_SHADING_H

#include "model.h"
#include "shading.h"

VX_INLINE vec3 average_shading(vec3 albedo, vec3 mean_normal, float specular, float roughness, unsigned int double_sided,
                               const vx_query *q)
{
    float len = vx_fminf(v3_length(mean_normal), 1.0f);
    vec3 n = v3_normalize_or(mean_normal, q->to_viewer);
    if (double_sided && v3_dot(n, q->to_viewer) < 0.0f)
        n = v3_scale(n, -1.0f);
    vec3 sum = v3(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < q->light_count; i++) {
        float cos_l = vx_fmaxf(0.0f, v3_dot(n, q->to_light[i]));
        float diffuse = (len * cos_l + (1.0f - len) * 0.25f) / VX_PI;
        vec3 f = v3_scale(albedo, diffuse);
        if ((q->effects & VX_EFFECT_SPECULAR) && cos_l > 0.0f) {
            float spec = len * cos_l * shading_specular_brdf(n, q->to_viewer, q->to_light[i], specular, roughness);
            f = v3_add(f, v3(spec, spec, spec));
        }
        sum = v3_add(sum, v3_mul(f, q->irradiance[i]));
    }
    return sum;
}

#endif
