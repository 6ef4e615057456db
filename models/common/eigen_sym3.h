/* Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations, in double: a 3x3
 * converges in a handful of sweeps and the method stays accurate for the repeated and zero
 * eigenvalues that planes, pairs of opposite normals and single normals produce. Bake-side (host)
 * code shared by the models that fit frames to normals or positions (vmesh, heitz-neyret). */
#ifndef VX_EIGEN_SYM3_H
#define VX_EIGEN_SYM3_H

#include <math.h>
#include <string.h>

/* Eigenvalues in w, the matching unit eigenvectors in the columns of v (unsorted). */
static inline void eigen_sym3(const double a_in[3][3], double w[3], double v[3][3])
{
    double a[3][3];
    memcpy(a, a_in, sizeof a);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            v[i][k] = i == k;
    for (int sweep = 0; sweep < 32; sweep++) {
        double off = fabs(a[0][1]) + fabs(a[0][2]) + fabs(a[1][2]);
        if (!(off > 1e-300))
            break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (!(fabs(a[p][q]) > 1e-300))
                    continue;
                /* The rotation that zeroes a[p][q] (Numerical Recipes' stable form). */
                double theta = 0.5 * (a[q][q] - a[p][p]) / a[p][q];
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < 3; k++) { /* A <- A J */
                    double akp = a[k][p], akq = a[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; k++) { /* A <- J^T A */
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
    for (int i = 0; i < 3; i++)
        w[i] = a[i][i];
}

/* The indices of w's eigenvalues in decreasing order (the dominant axis first). */
static inline void eigen_sym3_order_desc(const double w[3], int order[3])
{
    order[0] = 0, order[1] = 1, order[2] = 2;
    for (int i = 0; i < 3; i++)
        for (int j = i + 1; j < 3; j++)
            if (w[order[j]] > w[order[i]]) {
                int t = order[i];
                order[i] = order[j];
                order[j] = t;
            }
}

#endif
