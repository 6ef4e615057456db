/* What the averages baselines' records (`binary`, `alpha`) may hold, for vx_model.validate_record.
 * Host code only. The bounds are those of the bake (average_bake.h): means of the scene's
 * non-negative albedos (textures may exceed 1), of unit normals (so length <= 1), of specular
 * reflectances in [0, 1] and roughnesses in [1e-3, 2] (0 without front hits), flags 0 or 1. */
#ifndef VX_AVERAGE_VALIDATE_H
#define VX_AVERAGE_VALIDATE_H

#include <math.h>
#include <stdio.h>

static inline int average_validate_fields(const float color[3], const float normal[3], float specular,
                                          float roughness, unsigned int double_sided, char *why, size_t why_size)
{
    for (int c = 0; c < 3; c++)
        if (!isfinite(color[c]) || color[c] < 0.0f) {
            snprintf(why, why_size, "color[%d]: %g (expected a finite value >= 0)", c, (double)color[c]);
            return -1;
        }
    double len2 = 0.0;
    for (int c = 0; c < 3; c++) {
        if (!isfinite(normal[c])) {
            snprintf(why, why_size, "normal[%d]: %g (expected a finite value)", c, (double)normal[c]);
            return -1;
        }
        len2 += (double)normal[c] * (double)normal[c];
    }
    /* A mean of unit normals; the tolerance covers float rounding of the sum. */
    if (len2 > 1.0 + 1e-4) {
        snprintf(why, why_size, "normal: length %g (expected at most 1: a mean of unit normals)", sqrt(len2));
        return -1;
    }
    if (!(specular >= 0.0f && specular <= 1.0f)) {
        snprintf(why, why_size, "specular: %g (expected 0..1)", (double)specular);
        return -1;
    }
    if (!(roughness >= 0.0f && roughness <= 2.0f)) {
        snprintf(why, why_size, "roughness: %g (expected 0..2)", (double)roughness);
        return -1;
    }
    if (double_sided > 1u) {
        snprintf(why, why_size, "double_sided: %u (expected 0 or 1)", double_sided);
        return -1;
    }
    return 0;
}

#endif
