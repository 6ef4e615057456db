/* SGGX fit to a voxel's normals (sggx_fit.h), with the shared Jacobi eigen-decomposition
 * (eigen_sym3.h). */
#include <math.h>

#include "eigen_sym3.h"
#include "sggx_fit.h"

void sggx_fit(const vec3 *normals, int n, float min_area, sggx_frame *out)
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
    double w[3], v[3][3];
    eigen_sym3(e, w, v);
    /* Decreasing eigenvalue: axis 0 is the dominant normal direction. */
    int order[3];
    eigen_sym3_order_desc(w, order);
    vec3 ax[3];
    for (int k = 0; k < 3; k++)
        ax[k] = v3_normalize((vec3){(float)v[0][order[k]], (float)v[1][order[k]], (float)v[2][order[k]]});
    /* Right-handed (vmesh's octahedron faces then wind outward, vmesh_record.h). */
    ax[2] = v3_normalize(v3_cross(ax[0], ax[1]));
    for (int k = 0; k < 3; k++) {
        double sum = 0.0;
        for (int i = 0; i < n; i++)
            sum += fabs((double)v3_dot(ax[k], normals[i]));
        float l = (float)(sum / (double)n);
        out->axis[k] = ax[k];
        out->area[k] = vx_fminf(vx_fmaxf(l, min_area), 1.0f);
    }
}
