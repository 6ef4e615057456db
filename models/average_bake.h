/* Bake side of the averages baselines (`binary`, `alpha`): the means over a voxel's front-facing
 * hits. Host code only (the records' evaluation is in *_eval.h). */
#ifndef VX_AVERAGE_BAKE_H
#define VX_AVERAGE_BAKE_H

#include "model.h"

/* Writes the mean colour, mean normal (length <= 1: it shrinks when the normals disagree), mean
 * specular reflectance and roughness of the INSIDE_FRONT samples, and returns how many there were;
 * with none, the outputs are left untouched. */
static inline int average_front_hits(const vx_sample *samples, int n, float color[3], float normal[3],
                                     float *specular, float *roughness)
{
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
    if (!hits)
        return 0;
    float inv = 1.0f / (float)hits;
    c = v3_scale(c, inv);
    nrm = v3_scale(nrm, inv);
    color[0] = c.x, color[1] = c.y, color[2] = c.z;
    normal[0] = nrm.x, normal[1] = nrm.y, normal[2] = nrm.z;
    *specular = spec * inv;
    *roughness = rough * inv;
    return hits;
}

#endif
