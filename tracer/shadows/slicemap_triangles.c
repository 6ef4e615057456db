/* The slicemap of one light from the scene's triangles (Eisemann & Décoret §2.2, §3.1), on the CPU
 * with Embree rays in place of the GPU's rasteriser: the rasteriser makes one fragment per column a
 * primitive covers, at the column's centre; here the column's central ray finds every surface it
 * crosses, nearest first. A surface of a material with a "shadow_sigma" (foliage) sets the bit of
 * its slice and absorbs σ there (several in one slice: one bit, the largest σ, as one bit of the
 * paper's slicemap is one cell); the first surface of any other material is the column's opaque
 * depth (the paper's standard shadow map for solid objects) and ends the column. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "parallel.h"
#include "rt.h"
#include "scene_tris.h"
#include "shadow_build_internal.h"

typedef struct {
    const scene *s;
    const rt_scene *rt;
    map_build *b;
    float *scratch; /* per thread: slices floats */
} tri_job;

static void tri_row(void *p, int64_t row, int thread)
{
    tri_job *j = p;
    map_build *b = j->b;
    const scene *s = j->s;
    int S = b->m.slices, res = b->m.res, jj = (int)row;
    float *att = j->scratch + (size_t)thread * 2 * (size_t)S, *cum = att + S;
    float eps = 1e-6f * b->len;
    for (int i = 0; i < res; i++) {
        memset(att, 0, (size_t)S * sizeof *att);
        vec3 org, dir;
        shadow_column_ray(b, i, jj, 0, &org, &dir);
        float tn = 0.0f;
        for (;;) {
            struct RTCRayHit rh;
            rh.ray.org_x = org.x, rh.ray.org_y = org.y, rh.ray.org_z = org.z;
            rh.ray.dir_x = dir.x, rh.ray.dir_y = dir.y, rh.ray.dir_z = dir.z;
            rh.ray.tnear = tn;
            rh.ray.tfar = b->len;
            rh.ray.time = 0.0f;
            rh.ray.mask = 0xffffffffu;
            rh.ray.id = 0;
            rh.ray.flags = 0;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            struct RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            rtcIntersect1(j->rt->bvh, &ctx, &rh);
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
                break;
            float t = rh.ray.tfar;
            float sigma = s->shadow_sigma[scene_hit_material(s, rh.hit.instID[0], rh.hit.primID)];
            if (!(sigma > 0.0f)) {
                b->opaque[(size_t)jj * (size_t)res + (size_t)i] = t;
                break;
            }
            int k = shadow_slice(b, t);
            att[k] = vx_fmaxf(att[k], sigma);
            tn = t + eps;
        }
        float T = 1.0f;
        for (int k = 0; k < S; k++) {
            if (att[k] > 0.0f)
                T *= 1.0f - att[k];
            cum[k] = T;
        }
        shadow_column_finish(b, i, jj, cum);
    }
}

int slicemap_fill_triangles(const scene *s, map_build *b, int threads, vx_err *e)
{
    rt_scene rt;
    if (rt_build(&rt, s, e))
        return -1;
    int n = parallel_threads(threads);
    tri_job j = {s, &rt, b, malloc((size_t)n * 2 * (size_t)b->m.slices * sizeof(float))};
    if (!j.scratch) {
        rt_free(&rt);
        return vx_fail(e, "out of memory for the slicemap build");
    }
    parallel_for(b->m.res, n, tri_row, &j, NULL);
    free(j.scratch);
    rt_free(&rt);
    return 0;
}
