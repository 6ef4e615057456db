/* `vmesh`: the normals one face of the virtual octahedron stores (Brito et al. 2023, §3.3; see
 * vmesh_bake.h). Fixed sets of 1-3 distinct normals are kept as they are; a face with more holds a
 * distribution, summarised by three extremal normals on the cone around its mean normal. */
#include <math.h>
#include <stdlib.h>

#include "shading.h"
#include "vmesh_bake.h"

#define COS_DISTINCT 0.99619470f /* normals less than 5 degrees apart are the same normal */
#define MIN_CONE 0.1f            /* smallest cone opening (rad), as the authors' code */
#define AZIMUTHS 16              /* candidate positions of the 2nd and 3rd extremal normal */
/* Weight of the empty part of the cone against the enclosed normals. Every triangle inscribed in
 * the cone leaves part of it out; with normals spread over the whole cone this still prefers the
 * largest (equilateral) triangle, with normals in a wedge it prefers the triangle around the wedge. */
#define EMPTY_WEIGHT 0.3f

/* Puts k (1..3) candidate normals on k distinct vertices, each where it points most along the
 * vertex (the largest total alignment over all placements); the other vertices get the zero vector,
 * which the record keeps as "no normal here". */
static void place_on_vertices(const vec3 *cand, int k, const vec3 dir[3], vec3 out[3])
{
    static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    float best = -INFINITY;
    int best_p = 0;
    for (int p = 0; p < 6; p++) { /* candidate j goes to vertex perm[p][j] */
        float score = 0.0f;
        for (int j = 0; j < k; j++)
            score += v3_dot(cand[j], dir[perm[p][j]]);
        if (score > best) {
            best = score;
            best_p = p;
        }
    }
    out[0] = out[1] = out[2] = v3(0, 0, 0);
    for (int j = 0; j < k; j++)
        out[perm[best_p][j]] = cand[j];
}

static float cross2(float ax, float ay, float bx, float by) { return ax * by - ay * bx; }

/* Three extremal normals of a distribution: positions on the cone around the mean normal m in the
 * azimuthal-equidistant chart (polar angle from m, azimuth around it), where the cone is a circle
 * and a triangle of normals is (nearly) a triangle. */
static void extremal_normals(const vec3 *normals, int n, vec3 out[3])
{
    vec3 sum = v3(0, 0, 0);
    for (int i = 0; i < n; i++)
        sum = v3_add(sum, normals[i]);
    vec3 m = v3_normalize_or(sum, normals[0]);
    vec3 t, b;
    v3_basis(m, &t, &b);
    float stack[2 * 256];
    float *p = n <= 256 ? stack : malloc(sizeof(float) * 2 * (size_t)n);
    if (!p) { /* out of memory: a degenerate but valid cone of the mean normal */
        out[0] = out[1] = out[2] = m;
        return;
    }
    float theta_max = 0.0f, phi0 = 0.0f;
    for (int i = 0; i < n; i++) {
        float th = acosf(vx_fminf(vx_fmaxf(v3_dot(normals[i], m), -1.0f), 1.0f));
        float phi = atan2f(v3_dot(normals[i], b), v3_dot(normals[i], t));
        p[2 * i] = th * cosf(phi);
        p[2 * i + 1] = th * sinf(phi);
        if (th > theta_max) {
            theta_max = th;
            phi0 = phi; /* the first extremal normal: the one at theta_max */
        }
    }
    float cone = vx_fminf(vx_fmaxf(theta_max, MIN_CONE), 0.5f * VX_PI);
    float eps = 1e-4f * cone * cone, disk = VX_PI * cone * cone;
    float best = -INFINITY, best_phi[3] = {phi0, phi0 + 2.0f * VX_PI / 3.0f, phi0 + 4.0f * VX_PI / 3.0f};
    float x0 = cone * cosf(phi0), y0 = cone * sinf(phi0);
    for (int i = 1; i < AZIMUTHS - 1; i++)
        for (int j = i + 1; j < AZIMUTHS; j++) {
            float f1 = phi0 + 2.0f * VX_PI * (float)i / AZIMUTHS, f2 = phi0 + 2.0f * VX_PI * (float)j / AZIMUTHS;
            float x1 = cone * cosf(f1), y1 = cone * sinf(f1), x2 = cone * cosf(f2), y2 = cone * sinf(f2);
            /* Counter-clockwise: the azimuths increase. */
            float area = 0.5f * cross2(x1 - x0, y1 - y0, x2 - x0, y2 - y0);
            int inside = 0;
            for (int k = 0; k < n; k++) {
                float px = p[2 * k], py = p[2 * k + 1];
                inside += cross2(x1 - x0, y1 - y0, px - x0, py - y0) >= -eps &&
                          cross2(x2 - x1, y2 - y1, px - x1, py - y1) >= -eps &&
                          cross2(x0 - x2, y0 - y2, px - x2, py - y2) >= -eps;
            }
            float score = (float)inside / (float)n - EMPTY_WEIGHT * area / disk;
            if (score > best) {
                best = score;
                best_phi[1] = f1;
                best_phi[2] = f2;
            }
        }
    if (p != stack)
        free(p);
    float c = cosf(cone), s = sinf(cone);
    for (int k = 0; k < 3; k++)
        out[k] = v3_normalize(v3_add(v3_scale(m, c), v3_scale(v3_add(v3_scale(t, cosf(best_phi[k])),
                                                                        v3_scale(b, sinf(best_phi[k]))), s)));
}

void vmesh_fit_face(const vec3 *normals, int n, const vec3 vertex_dir[3], vmesh_face_fit *out)
{
    out->distribution = 0;
    out->distinct = 0;
    out->normal[0] = out->normal[1] = out->normal[2] = v3(0, 0, 0);
    if (n <= 0)
        return;
    /* Greedy clustering: a normal joins the first cluster whose first normal is within 5 degrees. */
    vec3 rep[3], sum[3];
    int clusters = 0, many = 0;
    for (int i = 0; i < n && !many; i++) {
        int j = 0;
        while (j < clusters && v3_dot(normals[i], rep[j]) < COS_DISTINCT)
            j++;
        if (j < clusters)
            sum[j] = v3_add(sum[j], normals[i]);
        else if (clusters < 3) {
            rep[clusters] = sum[clusters] = normals[i];
            clusters++;
        } else
            many = 1;
    }
    vec3 cand[3];
    if (many) {
        out->distribution = 1;
        out->distinct = 4;
        extremal_normals(normals, n, cand);
        place_on_vertices(cand, 3, vertex_dir, out->normal);
        return;
    }
    out->distinct = clusters;
    for (int j = 0; j < clusters; j++)
        cand[j] = v3_normalize_or(sum[j], rep[j]);
    place_on_vertices(cand, clusters, vertex_dir, out->normal);
}
