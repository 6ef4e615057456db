/* `vmesh` moving records (issue 17; vx_model.transform and .combine, models/model.h): a record seen
 * after a rotation, and the parts put into one voxel merged into one record. Host code only.
 *
 *  - transform: the octahedron's axes and every stored face normal turn (R v, re-quantised). Faces
 *    are indexed by octant of the axes (vmesh_record.h), so a face keeps its index, its colour and
 *    its distribution bit; a proper rotation keeps the frame right-handed. The 3x3x3 opacity subgrid
 *    is resampled in the turned frame: target sub-cell centre c reads the source at R^T c,
 *    trilinear with clamping (exact for quarter turns, which permute the sub-cells).
 *  - combine: each split piece's subgrid is shifted by its offset (a record placed whole, nearest's,
 *    snaps unshifted) and the parts' coverages united; the
 *    SGGX matrices are mixed by mass (weight x mean opacity) and decomposed again; the faces are
 *    refitted, with the bake's own fitting, from every stored face normal of every part. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "average_move.h"
#include "eigen_sym3.h"
#include "vmesh_bake.h"

static vec3 rotate(const float R[9], vec3 v)
{
    return v3(R[0] * v.x + R[1] * v.y + R[2] * v.z, R[3] * v.x + R[4] * v.y + R[5] * v.z,
              R[6] * v.x + R[7] * v.y + R[8] * v.z);
}

static int is_zero(const signed char q[3]) { return !(q[0] | q[1] | q[2]); }

/* Sub-cell index of lattice position u (sub-cell centres at 0, 1, 2), trilinear with clamping:
 * the lower index (0 or 1) and the fraction toward the next. */
static int lerp_index(float u, float *frac)
{
    u = vx_fminf(vx_fmaxf(u, 0.0f), 2.0f);
    int i = u >= 1.0f ? 1 : 0;
    *frac = u - (float)i;
    return i;
}

static void turn_subgrid(const unsigned char in[VMESH_SUBCELLS], const float R[9], unsigned char out[VMESH_SUBCELLS])
{
    for (int i = 0; i < VMESH_SUB; i++)
        for (int j = 0; j < VMESH_SUB; j++)
            for (int k = 0; k < VMESH_SUB; k++) {
                /* In sub-cell units about the voxel's centre: integers, so that a quarter turn's
                 * R^T c is exact and lands on a sub-cell centre. */
                float c[3] = {(float)(i - 1), (float)(j - 1), (float)(k - 1)}, f[3];
                int lo[3];
                for (int a = 0; a < 3; a++) /* (R^T c)_a = sum_b R[b][a] c_b */
                    lo[a] = lerp_index(R[a] * c[0] + R[3 + a] * c[1] + R[6 + a] * c[2] + 1.0f, &f[a]);
                float v = 0.0f;
                for (int corner = 0; corner < 8; corner++) {
                    float w = 1.0f;
                    int s[3];
                    for (int a = 0; a < 3; a++) {
                        int up = (corner >> a) & 1;
                        w *= up ? f[a] : 1.0f - f[a];
                        s[a] = lo[a] + up;
                    }
                    if (w > 0.0f)
                        v += w * (float)in[(s[0] * VMESH_SUB + s[1]) * VMESH_SUB + s[2]];
                }
                out[(i * VMESH_SUB + j) * VMESH_SUB + k] = (unsigned char)vx_fminf(roundf(v), 255.0f);
            }
}

void vmesh_transform(const void *in, const float R[9], void *out)
{
    const vmesh_record *a = in;
    vmesh_record r = *a;
    if (!average_is_identity(R)) {
        /* A record without faces has zero axes (vmesh_validate requires it): nothing to turn. The
         * decoded frame (orthonormal, right-handed) turns, not the raw bytes, so the
         * re-quantisation starts from a clean frame. */
        if (a->faces) {
            vmesh_octahedron o = vmesh_decode_octahedron(a);
            for (int k = 0; k < 3; k++)
                vmesh_encode_vec(rotate(R, o.axis[k]), r.axis[k]);
        }
        for (int f = 0; f < VMESH_FACES; f++)
            for (int k = 0; k < 3; k++)
                if (!is_zero(a->normal[f][k])) /* (0,0,0) means "no normal here" and must stay so */
                    vmesh_encode_vec(rotate(R, v3_normalize(vmesh_decode_vec(a->normal[f][k]))), r.normal[f][k]);
        turn_subgrid(a->opacity, R, r.opacity);
    }
    *(vmesh_record *)out = r;
}

/* Length of [lo0, lo0 + 1] inside [lo1, lo1 + 1]. */
static float overlap1(float lo0, float lo1)
{
    return vx_fmaxf(0.0f, 1.0f - fabsf(lo0 - lo1));
}

/* A part's subgrid (opacities in [0, 1]) moved by d sub-cells (its offset x 3) into the target
 * voxel: each target sub-cell takes the source sub-cells in proportion to the volume they overlap
 * it (a box filter: for shifts by whole sub-cells a permutation; what stays inside the target is
 * conserved, which split8's pieces need to add up to the record); outside the part's cube nothing. */
static void shift_subgrid(const unsigned char in[VMESH_SUBCELLS], const float d[3], float out[VMESH_SUBCELLS])
{
    float w[3][VMESH_SUB][VMESH_SUB]; /* per axis: target index, source index */
    for (int a = 0; a < 3; a++)
        for (int t = 0; t < VMESH_SUB; t++)
            for (int s = 0; s < VMESH_SUB; s++)
                w[a][t][s] = overlap1((float)t, (float)s + d[a]);
    for (int i = 0; i < VMESH_SUB; i++)
        for (int j = 0; j < VMESH_SUB; j++)
            for (int k = 0; k < VMESH_SUB; k++) {
                float v = 0.0f;
                for (int x = 0; x < VMESH_SUB; x++)
                    for (int y = 0; y < VMESH_SUB; y++)
                        for (int z = 0; z < VMESH_SUB; z++) {
                            float ww = w[0][i][x] * w[1][j][y] * w[2][k][z];
                            if (ww > 0.0f)
                                v += ww * vmesh_decode_unorm(in[(x * VMESH_SUB + y) * VMESH_SUB + z]);
                        }
                out[(i * VMESH_SUB + j) * VMESH_SUB + k] = vx_fminf(v, 1.0f);
            }
}

/* How a part enters the cell: shifted by its offset (*shift = 1) with the share of its coverage
 * the cell holds beyond what the shifted subgrid already says, weight / (the volume its unit cube
 * overlaps the cell): split8's weights are exactly that volume (share 1: the shift did the
 * splitting); two halves of one record at offset 0 have share 1/2. A record placed whole (weight 1:
 * nearest's, and static parts at offset 0) enters unshifted with share 1: nearest snaps the voxel
 * into the cell, as the dynamic-SVO paper's nearest filtering does (§3.3, Fig. 1a). Shifted by its
 * offset inside the cell, a record moved by half a cell kept an eighth of its subgrid and the rest
 * was cut off: an object moved by (0.5, 0.5, 0.5) cells turned mostly transparent, at every
 * resolution (the fidelity audit: MSE 3.4e-3 at 128^3 where the re-bake's is 6.6e-4). A scaled
 * object's placements (tracer/dynamic/: the record's cube of edge s spread over the cells it
 * overlaps, weight = covered volume / s) have a weight above that volume or an offset beyond the
 * unit cube; a shift would cut their content off and open holes, so they enter unshifted, thinned
 * by their weight (s cells along a ray then keep the record's opacity). */
static float coverage_share(const vx_record_part *p, int *shift)
{
    float ov = 1.0f;
    for (int a = 0; a < 3; a++)
        ov *= vx_fmaxf(0.0f, 1.0f - fabsf(p->offset[a]));
    *shift = ov > 0.0f && p->weight < 1.0f && p->weight <= ov * 1.001f;
    if (!*shift)
        return vx_fminf(vx_fmaxf(p->weight, 0.0f), 1.0f);
    return vx_fminf(p->weight / ov, 1.0f);
}

static float mean_opacity(const vmesh_record *r)
{
    int sum = 0;
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        sum += r->opacity[c];
    return (float)sum / (255.0f * VMESH_SUBCELLS);
}

/* The SGGX frame of the parts' mixed matrices S = sum_k lambda_k^2 v_k v_k^T (vmesh_record.h:
 * lambda are the stored projected areas, clamped as the decoder does), decomposed again: axes by
 * decreasing eigenvalue and right-handed, areas sqrt(eigenvalue) clamped as the bake's fit. */
static void mix_frames(const vx_record_part *parts, const float *mass, int n, sggx_frame *fit)
{
    double S[3][3] = {{0}}, M = 0;
    for (int i = 0; i < n; i++) {
        const vmesh_record *a = parts[i].record;
        if (!a->faces || !(mass[i] > 0.0f))
            continue;
        vmesh_octahedron o = vmesh_decode_octahedron(a);
        for (int k = 0; k < 3; k++) {
            double l = vx_fmax(vmesh_decode_unorm(a->area[k]), VMESH_MIN_AREA), v[3] = {o.axis[k].x, o.axis[k].y, o.axis[k].z};
            for (int p = 0; p < 3; p++)
                for (int q = 0; q < 3; q++)
                    S[p][q] += mass[i] * l * l * v[p] * v[q];
        }
        M += mass[i];
    }
    double w[3], V[3][3];
    for (int p = 0; p < 3; p++)
        for (int q = 0; q < 3; q++)
            S[p][q] /= M;
    eigen_sym3(S, w, V);
    int order[3];
    eigen_sym3_order_desc(w, order);
    for (int k = 0; k < 3; k++) {
        fit->axis[k] = v3_normalize(v3((float)V[0][order[k]], (float)V[1][order[k]], (float)V[2][order[k]]));
        fit->area[k] = vx_fminf(vx_fmaxf((float)sqrt(vx_fmax(w[order[k]], 0.0)), VMESH_MIN_AREA), 1.0f);
    }
    fit->axis[2] = v3_normalize(v3_cross(fit->axis[0], fit->axis[1])); /* right-handed, as the bake */
}

/* Every stored face normal of every part with mass, with its face's colour and the part's mass, and
 * the faces refitted in r's (already encoded) frame. A stored face's normals are sorted together by
 * their mean (a distribution's extremal normals may lie outside its octant), and a face that
 * received a distribution's normals and still holds three is a distribution again (the clustering
 * sees three distinct normals and would otherwise pick the nearest instead of interpolating). */
static void refit_faces(vmesh_record *r, const vx_record_part *parts, const float *mass, int n)
{
    int total = 0;
    for (int i = 0; i < n; i++)
        if (mass[i] > 0.0f)
            total += VMESH_FACES * 3;
    if (!total)
        return;
    vec3 *buf = malloc((size_t)total * (4 * sizeof(vec3) + sizeof(float) + 2 * sizeof(int)));
    if (!buf)
        return; /* out of memory: the frame and opacities alone, an unshaded occluder */
    vec3 *normal = buf, *albedo = buf + total, *dir = buf + 2 * total, *sorted = buf + 3 * total;
    float *weight = (float *)(buf + 4 * total);
    int *face = (int *)(weight + total), *dist = face + total, m = 0;
    for (int i = 0; i < n; i++) {
        const vmesh_record *a = parts[i].record;
        if (!(mass[i] > 0.0f))
            continue;
        for (int f = 0; f < VMESH_FACES; f++) {
            if (!((a->faces >> f) & 1))
                continue;
            int start = m;
            vec3 sum = v3(0, 0, 0);
            for (int k = 0; k < 3; k++) {
                if (is_zero(a->normal[f][k]))
                    continue;
                normal[m] = v3_normalize(vmesh_decode_vec(a->normal[f][k]));
                albedo[m] = v3(vmesh_decode_unorm(a->color[f][0]), vmesh_decode_unorm(a->color[f][1]),
                               vmesh_decode_unorm(a->color[f][2]));
                weight[m] = mass[i];
                dist[m] = (a->distribution >> f) & 1;
                sum = v3_add(sum, normal[m]);
                m++;
            }
            for (int j = start; j < m; j++)
                dir[j] = v3_normalize_or(sum, normal[j]);
        }
    }
    vmesh_build_faces(r, normal, albedo, weight, dir, m, face, sorted);
    for (int j = 0; j < m; j++) {
        int f = face[j];
        if (dist[j] && !is_zero(r->normal[f][0]) && !is_zero(r->normal[f][1]) && !is_zero(r->normal[f][2]))
            r->distribution |= (unsigned char)(1u << f);
    }
    free(buf);
}

void vmesh_combine(const vx_record_part *parts, int n, float voxel_size, void *out)
{
    (void)voxel_size; /* nothing in the record is a length */
    if (n == 1 && parts[0].weight == 1.0f && parts[0].offset[0] == 0.0f && parts[0].offset[1] == 0.0f &&
        parts[0].offset[2] == 0.0f) {
        *(vmesh_record *)out = *(const vmesh_record *)parts[0].record;
        return;
    }
    vmesh_record r;
    memset(&r, 0, sizeof r);
    /* Opacity: the union of the parts' coverages, 1 - prod (1 - o_i)^share_i (share 1: the plain
     * union of overlapping parts; two halves of a record give the record back). */
    double clear[VMESH_SUBCELLS];
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        clear[c] = 1.0;
    float stack_mass[16], *mass = n <= 16 ? stack_mass : malloc(sizeof(float) * (size_t)n);
    if (!mass) { /* out of memory: the first part, still a valid record */
        *(vmesh_record *)out = *(const vmesh_record *)parts[0].record;
        return;
    }
    double M = 0, faced = 0;
    for (int i = 0; i < n; i++) {
        const vmesh_record *a = parts[i].record;
        int shift;
        double share = coverage_share(&parts[i], &shift);
        float d[3] = {0, 0, 0}, o[VMESH_SUBCELLS];
        for (int k = 0; shift && k < 3; k++)
            d[k] = 3.0f * parts[i].offset[k];
        shift_subgrid(a->opacity, d, o);
        for (int c = 0; c < VMESH_SUBCELLS; c++)
            clear[c] *= o[c] >= 1.0f ? 0.0 : pow(1.0 - (double)o[c], share);
        /* What the part adds to the look: its covered fraction times its mean opacity. */
        mass[i] = a->faces ? vx_fmaxf(parts[i].weight, 0.0f) * mean_opacity(a) : 0.0f;
        M += mass[i];
        faced += a->faces ? 1 : 0;
    }
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        r.opacity[c] = vmesh_encode_unorm((float)(1.0 - clear[c]));
    if (!(M > 0) && faced > 0) /* faces but no opacity anywhere: the plain weights */
        for (int i = 0; i < n; i++) {
            mass[i] = ((const vmesh_record *)parts[i].record)->faces ? vx_fmaxf(parts[i].weight, 0.0f) : 0.0f;
            M += mass[i];
        }
    if (M > 0) {
        sggx_frame fit;
        mix_frames(parts, mass, n, &fit);
        vmesh_encode_frame(&r, &fit);
        refit_faces(&r, parts, mass, n);
        double spec = 0, alpha = 0;
        for (int i = 0; i < n; i++) {
            const vmesh_record *a = parts[i].record;
            double s = vmesh_decode_unorm(a->roughness);
            spec += mass[i] * vmesh_decode_unorm(a->specular);
            alpha += mass[i] * 2.0 * s * s; /* stored as sqrt(alpha / 2), as the bake's mean */
        }
        r.specular = vmesh_encode_unorm((float)(spec / M));
        r.roughness = vmesh_encode_unorm((float)sqrt(0.5 * alpha / M));
        if (!r.faces) { /* no normal survived: no frame either (vmesh_validate) */
            memset(r.axis, 0, sizeof r.axis);
            memset(r.area, 0, sizeof r.area);
        }
    }
    if (mass != stack_mass)
        free(mass);
    *(vmesh_record *)out = r;
}
