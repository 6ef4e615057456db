/* SGGX fit to a set of unit normals (Heitz et al. 2015, as Brito et al.'s released code does it):
 * eigenvectors of the second moment E = (1/N) sum n n^T, sorted by decreasing eigenvalue and made
 * right-handed; projected areas lambda_k = (1/N) sum |v_k . n| clamped to [min_area, 1] (the SGGX
 * matrix is S = R diag(lambda^2) R^T). No normals give the identity frame and lambda = 1/2 each,
 * the value of normals uniform on the sphere: no preferred orientation. Host code, shared by the
 * models that store an SGGX distribution (vmesh orients its octahedron with it, vicini stores S). */
#ifndef VX_SGGX_FIT_H
#define VX_SGGX_FIT_H

#include "vec.h"

typedef struct {
    vec3 axis[3];
    float area[3];
} sggx_frame;

void sggx_fit(const vec3 *normals, int n, float min_area, sggx_frame *out);

#endif
