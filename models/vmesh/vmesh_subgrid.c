/* `vmesh`: the 3x3x3 subgrid of opacities (Brito et al. 2023, §3.2 and §3.4; see vmesh_bake.h).
 *
 * Our reading of the paper's counting, written down because the paper leaves it to the reader:
 *  - A ray's occlusion value is the shared classification's (models/model.h, tracer/bake/bake.h): 1 for
 *    cases (a) (front or back) and (b) (the voxel's own triangle met outside it, before or after),
 *    0 for a miss (c).
 *  - The value is added to every sub-cell along the ray's whole chord [t_entry, t_exit], not only up
 *    to the hit: the paper adds "to the subgrid elements that the ray traversed" and spreads
 *    outside hits along the chord too, then localises the result with the special pass (sub-cells
 *    without a front-facing hit are cleared), which it likens to Vicini et al.'s extension of
 *    occlusion. This is the conservative side the paper reports (thicker occluders).
 *  - A sub-cell's opacity is the mean value over the rays whose chord crosses it.
 *
 * The chord's crossings of the inner sub-cell planes are sorted and walked from the sub-cell of its
 * entry point (at most 7 pieces). Pieces shorter than 1e-6 of the chord (a ray grazing an edge or
 * a corner) are not counted as a traversal. */
#include <math.h>

#include "vmesh_bake.h"

static int sub_index(float u) /* lattice coordinate in [0, 3] -> 0..2 */
{
    int i = (int)floorf(u);
    return i < 0 ? 0 : (i > VMESH_SUB - 1 ? VMESH_SUB - 1 : i);
}

int vmesh_chord_cells(vec3 e, vec3 d, float len, int cells[8])
{
    /* The inner planes (1 and 2 on each axis) the chord crosses, in the order it meets them on
     * that axis, then all of them sorted by distance: at most 6 crossings. The voxel's own faces
     * end the chord and are not crossings. (Written without libm's fminf/fmaxf, which are calls,
     * and with one division per axis: this runs for every sample ray.) */
    float ea[3] = {e.x, e.y, e.z}, da[3] = {d.x, d.y, d.z}, tc[6];
    int idx[3], move[6], m = 0; /* move: axis * 2 + (1 when the index grows) */
    for (int a = 0; a < 3; a++) {
        int i = sub_index(ea[a]);
        idx[a] = i;
        if (da[a] > 1e-12f) {
            float inv = 1.0f / da[a];
            for (int p = i + 1; p <= VMESH_SUB - 1; p++) {
                float t = ((float)p - ea[a]) * inv;
                if (t < len)
                    tc[m] = t, move[m++] = 2 * a + 1;
            }
        } else if (da[a] < -1e-12f) {
            float inv = 1.0f / da[a];
            for (int p = i; p >= 1; p--) {
                float t = ((float)p - ea[a]) * inv;
                if (t < len)
                    tc[m] = t, move[m++] = 2 * a;
            }
        }
    }
    for (int i = 1; i < m; i++) /* insertion sort; per axis the crossings are already in order */
        for (int j = i; j > 0 && tc[j] < tc[j - 1]; j--) {
            float t = tc[j];
            tc[j] = tc[j - 1], tc[j - 1] = t;
            int v = move[j];
            move[j] = move[j - 1], move[j - 1] = v;
        }
    float t = 0.0f, min_piece = 1e-6f * len;
    int count = 0;
    for (int k = 0; k <= m; k++) {
        float end = k < m ? tc[k] : len;
        if (end - t > min_piece)
            cells[count++] = (idx[0] * VMESH_SUB + idx[1]) * VMESH_SUB + idx[2];
        if (k < m) {
            t = end > t ? end : t;
            idx[move[k] >> 1] += (move[k] & 1) ? 1 : -1;
        }
    }
    return count;
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
        float occ = vx_sample_occludes(s) ? 1.0f : 0.0f;
        /* Work from the entry point (lattice units) so the far-away origin costs no precision. */
        vec3 e = v3_scale(v3_sub(v3_madd(s->origin, s->dir, s->t_entry), v->lo), scale);
        vec3 d = v3_scale(s->dir, scale);
        int cells[8];
        int m = vmesh_chord_cells(e, d, len, cells);
        for (int i = 0; i < m; i++) {
            rays[cells[i]] += 1.0f;
            value[cells[i]] += occ;
        }
        if (k == VX_SAMPLE_INSIDE_FRONT) {
            vec3 h = v3_madd(e, d, s->t_hit - s->t_entry);
            front[(sub_index(h.x) * VMESH_SUB + sub_index(h.y)) * VMESH_SUB + sub_index(h.z)] = 1;
        }
    }
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        opacity[c] = front[c] && rays[c] > 0.0f ? value[c] / rays[c] : 0.0f;
}
