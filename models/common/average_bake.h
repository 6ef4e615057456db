/* Bake side of the averages baselines (`binary`, `alpha`): the means over a voxel's front-facing
 * hits. Host code only (the records' evaluation is in *_eval.h). */
#ifndef VX_AVERAGE_BAKE_H
#define VX_AVERAGE_BAKE_H

#include "model.h"

/* Writes the mean colour, mean normal (length <= 1: it shrinks when the normals disagree), mean
 * specular reflectance and roughness of the INSIDE_FRONT samples, and returns how many there were;
 * with none, the outputs are left untouched. *double_sided: whether most of those hits were on a
 * double-sided material. Normals are summed on each surface's own front side
 * (vx_sample_front_normal): a double-sided sheet seen from both sides keeps its orientation instead
 * of averaging to nothing, and the shading turns it toward the viewer as the material says. */
static inline int average_front_hits(const vx_sample *samples, int n, float color[3], float normal[3],
                                     float *specular, float *roughness, unsigned int *double_sided)
{
    int hits = 0, two = 0;
    vec3 c = v3(0, 0, 0), nrm = v3(0, 0, 0);
    float spec = 0, rough = 0;
    for (int i = 0; i < n; i++)
        if (samples[i].kind == VX_SAMPLE_INSIDE_FRONT) {
            hits++;
            c = v3_add(c, samples[i].albedo);
            nrm = v3_add(nrm, vx_sample_front_normal(&samples[i]));
            two += samples[i].double_sided != 0;
            spec += samples[i].specular;
            rough += samples[i].roughness;
        }
    if (!hits)
        return 0;
    float inv = 1.0f / (float)hits;
    c = v3_scale(c, inv);
    nrm = v3_scale(nrm, inv);
    color[0] = c.x, color[1] = c.y, color[2] = c.z;
    normal[0] = nrm.x, normal[1] = nrm.y, normal[2] = nrm.z;
    *specular = spec * inv;
    *roughness = rough * inv;
    *double_sided = 2 * two > hits;
    return hits;
}

#endif
