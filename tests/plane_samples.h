/* Shared by the moving-record tests (unit_dynamic, unit_vmesh_move): the bake sampler's rays of a
 * unit voxel crossed by a plane, so that a record baked from them and one baked from the turned
 * rays can be compared. Test code only. */
#ifndef VX_TEST_PLANE_SAMPLES_H
#define VX_TEST_PLANE_SAMPLES_H

#include <math.h>
#include <string.h>

#include "model.h"

/* Samples of the unit voxel [-0.5, 0.5]^3 crossed by a double-sided plane with normal n0 at height
 * h along it (every ray meeting the plane occludes: inside the voxel a front hit, else OUTSIDE), the
 * hits' specular reflectance `specular`; rnd: the test's own random stream. */
static void plane_samples(vec3 n0, float h, float specular, int n, double (*rnd)(void), vx_sample *out)
{
    for (int i = 0; i < n; i++) {
        vx_sample *s = &out[i];
        memset(s, 0, sizeof *s);
        double z = 2 * rnd() - 1, a = 2 * M_PI * rnd(), r = sqrt(1 - z * z);
        vec3 d = v3((float)(r * cos(a)), (float)(r * sin(a)), (float)z);
        vec3 p = v3((float)(rnd() - 0.5), (float)(rnd() - 0.5), (float)(rnd() - 0.5));
        vec3 o = v3_madd(p, d, -4.0f);
        float t0 = -INFINITY, t1 = INFINITY;
        for (int k = 0; k < 3; k++) {
            float u = (-0.5f - v3_get(o, k)) / v3_get(d, k), v = (0.5f - v3_get(o, k)) / v3_get(d, k);
            t0 = fmaxf(t0, fminf(u, v));
            t1 = fminf(t1, fmaxf(u, v));
        }
        s->origin = o, s->dir = d, s->t_entry = t0, s->t_exit = t1, s->t_hit = INFINITY, s->kind = VX_SAMPLE_MISS;
        float dn = v3_dot(d, n0);
        if (fabsf(dn) > 1e-6f) {
            float t = (h - v3_dot(n0, o)) / dn;
            s->t_hit = t;
            if (t >= t0 && t <= t1) {
                s->kind = VX_SAMPLE_INSIDE_FRONT;
                s->double_sided = 1;
                s->back_side = dn > 0;
                s->normal = dn < 0 ? n0 : v3_scale(n0, -1);
                s->albedo = v3(0.6f, 0.4f, 0.2f);
                s->roughness = 0.3f;
                s->specular = specular;
            } else {
                s->kind = VX_SAMPLE_OUTSIDE;
            }
        }
    }
}

#endif
