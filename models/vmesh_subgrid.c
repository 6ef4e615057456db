/* `vmesh`: the 3x3x3 subgrid of opacities (Brito et al. 2023, §3.2 and §3.4; see vmesh_bake.h).
 *
 * Our reading of the paper's counting, written down because the paper leaves it to the reader:
 *  - A ray's occlusion value is 1 for a hit inside the voxel, front- or back-facing (case (a) and
 *    its back-facing variant), and 1 for a hit beyond the voxel on one of the voxel's own triangles
 *    (case (b): the paper intersects only the voxel's triangle list, so every "outside" hit it sees
 *    is an own triangle; our sampler traces the whole scene, and a hit on someone else's triangle
 *    is what the paper would have called a miss). Everything else is 0.
 *  - The value is added to every sub-cell along the ray's whole chord [t_entry, t_exit], not only up
 *    to the hit: the paper adds "to the subgrid elements that the ray traversed" and spreads
 *    outside hits along the chord too, then localises the result with the special pass (sub-cells
 *    without a front-facing hit are cleared), which it likens to Vicini et al.'s extension of
 *    occlusion. This is the conservative side the paper reports (thicker occluders).
 *  - A sub-cell's opacity is the mean value over the rays whose chord crosses it.
 *
 * The chord is cut at the sub-cell planes it crosses (at most 6), and each piece is attributed to
 * the sub-cell of its midpoint: exact, and free of the stepping corner cases of a DDA. Pieces
 * shorter than 1e-6 voxel (a ray grazing an edge) are ignored. */
#include <math.h>

#include "vmesh_bake.h"

static int sub_index(float u) /* lattice coordinate in [0, 3] -> 0..2 */
{
    int i = (int)floorf(u);
    return i < 0 ? 0 : (i > VMESH_SUB - 1 ? VMESH_SUB - 1 : i);
}

void vmesh_subgrid(const vx_voxel *v, const vx_sample *samples, int n, float opacity[VMESH_SUBCELLS])
{
    float value[VMESH_SUBCELLS] = {0}, rays[VMESH_SUBCELLS] = {0};
    int front[VMESH_SUBCELLS] = {0};
    float scale = (float)VMESH_SUB / v->size;
    for (int r = 0; r < n; r++) {
        const vx_sample *s = &samples[r];
        float len = s->t_exit - s->t_entry;
        if (!(len > 1e-6f * v->size))
            continue;
        int k = s->kind;
        float occ = (k == VX_SAMPLE_INSIDE_FRONT || k == VX_SAMPLE_INSIDE_BACK ||
                     (k == VX_SAMPLE_OUTSIDE && s->own_triangle)) ? 1.0f : 0.0f;
        /* Work from the entry point (lattice units) so the far-away origin costs no precision. */
        vec3 e = v3_scale(v3_sub(v3_madd(s->origin, s->dir, s->t_entry), v->lo), scale);
        vec3 d = v3_scale(s->dir, scale);
        float cut[8];
        int m = 0;
        cut[m++] = 0.0f;
        for (int a = 0; a < 3; a++) {
            float ea = v3_get(e, a), da = v3_get(d, a);
            if (fabsf(da) < 1e-12f)
                continue;
            for (int plane = 1; plane < VMESH_SUB; plane++) {
                float tc = ((float)plane - ea) / da;
                if (tc > 0.0f && tc < len)
                    cut[m++] = tc;
            }
        }
        cut[m++] = len;
        for (int i = 1; i < m; i++) /* insertion sort: at most 8 */
            for (int j = i; j > 0 && cut[j] < cut[j - 1]; j--) {
                float t = cut[j];
                cut[j] = cut[j - 1];
                cut[j - 1] = t;
            }
        for (int i = 0; i + 1 < m; i++) {
            if (!(cut[i + 1] - cut[i] > 1e-6f * len))
                continue;
            vec3 p = v3_madd(e, d, 0.5f * (cut[i] + cut[i + 1]));
            int c = (sub_index(p.x) * VMESH_SUB + sub_index(p.y)) * VMESH_SUB + sub_index(p.z);
            rays[c] += 1.0f;
            value[c] += occ;
        }
        if (k == VX_SAMPLE_INSIDE_FRONT) {
            vec3 h = v3_madd(e, d, s->t_hit - s->t_entry);
            front[(sub_index(h.x) * VMESH_SUB + sub_index(h.y)) * VMESH_SUB + sub_index(h.z)] = 1;
        }
    }
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        opacity[c] = front[c] && rays[c] > 0.0f ? value[c] / rays[c] : 0.0f;
}
