/* `vmesh`: SGGX fit to a voxel's front-facing normals (Heitz et al. 2015 as the authors' code does
 * it; see vmesh_bake.h). Eigen-decomposition by cyclic Jacobi rotations in double: a 3x3 symmetric
 * matrix converges in a handful of sweeps and the method stays accurate for the repeated and zero
 * eigenvalues that planes, pairs of opposite normals and single normals produce. */
#include <math.h>

#include "vmesh_bake.h"

/* Diagonalises the symmetric a in place (its diagonal ends as the eigenvalues); the columns of v
 * are the eigenvectors. */
static void jacobi3(double a[3][3], double v[3][3])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            v[i][j] = i == j;
    for (int sweep = 0; sweep < 32; sweep++) {
        double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if (off < 1e-30)
            break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (fabs(a[p][q]) < 1e-300)
                    continue;
                /* The rotation that zeroes a[p][q] (Numerical Recipes' stable form). */
                double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < 3; k++) { /* columns p, q */
                    double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; k++) { /* rows p, q */
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for (int k = 0; k < 3; k++) {
                    double vkp = v[k][p], vkq = v[k][q];
                    v[k][p] = c * vkp - s * vkq;
                    v[k][q] = s * vkp + c * vkq;
                }
            }
    }
}

void vmesh_sggx_fit(const vec3 *normals, int n, vmesh_sggx *out)
{
    out->axis[0] = v3(1, 0, 0);
    out->axis[1] = v3(0, 1, 0);
    out->axis[2] = v3(0, 0, 1);
    out->area[0] = out->area[1] = out->area[2] = 0.5f;
    if (n <= 0)
        return;
    double e[3][3] = {{0}};
    for (int i = 0; i < n; i++) {
        double x[3] = {normals[i].x, normals[i].y, normals[i].z};
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                e[r][c] += x[r] * x[c];
    }
    double v[3][3];
    jacobi3(e, v);
    /* Decreasing eigenvalue: axis 0 is the dominant normal direction. */
    int order[3] = {0, 1, 2};
    for (int i = 0; i < 3; i++)
        for (int j = i + 1; j < 3; j++)
            if (e[order[j]][order[j]] > e[order[i]][order[i]]) {
                int t = order[i];
                order[i] = order[j];
                order[j] = t;
            }
    vec3 ax[3];
    for (int k = 0; k < 3; k++)
        ax[k] = v3_normalize((vec3){(float)v[0][order[k]], (float)v[1][order[k]], (float)v[2][order[k]]});
    /* Right-handed, so that the octahedron's faces wind outward (vmesh_record.h). */
    ax[2] = v3_normalize(v3_cross(ax[0], ax[1]));
    for (int k = 0; k < 3; k++) {
        double sum = 0.0;
        for (int i = 0; i < n; i++)
            sum += fabs((double)v3_dot(ax[k], normals[i]));
        float l = (float)(sum / (double)n);
        out->axis[k] = ax[k];
        out->area[k] = fminf(fmaxf(l, VMESH_MIN_AREA), 1.0f);
    }
}
