/* Moving the averages baselines' records (`binary`, `alpha`; vx_model.transform and .combine):
 * their directional content is one mean normal, which rotates; everything else is a scalar. Host
 * code only. */
#ifndef VX_AVERAGE_MOVE_H
#define VX_AVERAGE_MOVE_H

#include <string.h>

#include "model.h"

/* out = R v (R row-major). */
static inline void average_rotate(const float R[9], const float v[3], float out[3])
{
    float x = v[0], y = v[1], z = v[2];
    out[0] = R[0] * x + R[1] * y + R[2] * z;
    out[1] = R[3] * x + R[4] * y + R[5] * z;
    out[2] = R[6] * x + R[7] * y + R[8] * z;
}

static inline int average_is_identity(const float R[9])
{
    static const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    return memcmp(R, I, sizeof I) == 0;
}

/* The shared fields of one record and the weight it enters the mean with. */
typedef struct {
    const float *color, *normal;
    float specular, roughness;
    unsigned int double_sided;
    float weight; /* covered fraction times the record's opacity: what it contributes to the look */
} average_view;

/* Weighted means of the shared fields (the mean normal keeps its length: it shrinks where the
 * parts disagree, as the bake's does); with no weight at all, the outputs are left as they are. */
static inline void average_combine_fields(const average_view *v, int n, float color[3], float normal[3],
                                          float *specular, float *roughness, unsigned int *double_sided)
{
    double W = 0, c[3] = {0, 0, 0}, nr[3] = {0, 0, 0}, sp = 0, ro = 0, two = 0;
    for (int i = 0; i < n; i++) {
        double w = v[i].weight;
        if (!(w > 0))
            continue;
        W += w;
        for (int k = 0; k < 3; k++) {
            c[k] += w * v[i].color[k];
            nr[k] += w * v[i].normal[k];
        }
        sp += w * v[i].specular;
        ro += w * v[i].roughness;
        two += v[i].double_sided ? w : 0.0;
    }
    if (!(W > 0))
        return;
    for (int k = 0; k < 3; k++) {
        color[k] = (float)(c[k] / W);
        normal[k] = (float)(nr[k] / W);
    }
    *specular = (float)(sp / W);
    *roughness = (float)(ro / W);
    *double_sided = 2.0 * two > W;
}

#endif
