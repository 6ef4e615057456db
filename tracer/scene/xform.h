/* An object's or an instance's placement: scale, then rotate about x, y, z (degrees), then
 * translate. One parser and one arithmetic (double, then rounded to float) for an object's
 * "transform" and an instance's, so that an instanced copy and the same object written out with
 * that transform get the same float vertices bit for bit. */
#ifndef VX_XFORM_H
#define VX_XFORM_H

#include <cjson/cJSON.h>
#include <stddef.h>

#include "error.h"
#include "mesh.h"
#include "vec.h"

typedef struct {
    vec3 scale, rotate_deg, translate;
} xform;

/* A placement ready to apply to many points: the rotation's cosines and sines computed once. */
typedef struct {
    vec3 scale, translate;
    double cs[3][2];
} xform_exact;

#define XFORM_IDENTITY ((xform){{1, 1, 1}, {0, 0, 0}, {0, 0, 0}})

/* Reads {"scale": s | [x,y,z], "rotate_deg": [x,y,z], "translate": [x,y,z]} (each optional; no
 * other field) into *out; `where` names the object for messages. A zero scale is refused. */
int xform_parse(const cJSON *obj, const char *where, xform *out, vx_err *e);
/* Applies x to the vertices from v0 on; normals by the inverse transpose (renormalised), and the
 * winding of the triangles from t0 on reversed when the scale mirrors, to keep fronts outside. */
void xform_apply(mesh *m, size_t v0, size_t t0, const xform *x);
void xform_prepare(const xform *x, xform_exact *out);

/* V rotated about x, then y, then z, by the angles whose cosines and sines are cs. Written out
 * axis by axis (the plane of axis k is (k+1, k+2) mod 3): the voxeliser places every corner of
 * every copy with it, and a loop computing the indices was a third of that time. */
#define XFORM_TURN(cs, V, k, a, b)                                                                            \
    do {                                                                                                     \
        double c_ = (cs)[k][0], s_ = (cs)[k][1];                                                             \
        double va_ = c_ * (V)[a] - s_ * (V)[b], vb_ = s_ * (V)[a] + c_ * (V)[b];                             \
        (V)[a] = va_, (V)[b] = vb_;                                                                          \
    } while (0)
static inline void xform_rotate(const double cs[3][2], double V[3])
{
    XFORM_TURN(cs, V, 0, 1, 2);
    XFORM_TURN(cs, V, 1, 2, 0);
    XFORM_TURN(cs, V, 2, 0, 1);
}
#undef XFORM_TURN

/* One point placed with exactly xform_apply's arithmetic (the same float result): instance copies
 * are placed on the fly by the voxeliser and the bake sampler with it. Inline: they place every
 * corner of every copy they visit. */
static inline void xform_point(const xform_exact *x, const float p[3], float out[3])
{
    double P[3] = {p[0] * x->scale.x, p[1] * x->scale.y, p[2] * x->scale.z};
    xform_rotate(x->cs, P);
    out[0] = (float)(P[0] + x->translate.x), out[1] = (float)(P[1] + x->translate.y);
    out[2] = (float)(P[2] + x->translate.z);
}
/* A normal placed by the inverse transpose and normalised, likewise (out may be n). */
void xform_normal(const xform_exact *x, const float n[3], float out[3]);
/* The same map as a row-major 3x4 matrix (p' = M[0..2] p + M[3] per row), in double. */
void xform_matrix(const xform *x, double M[12]);
/* 1 when the scale mirrors (its determinant is negative). */
int xform_mirrors(const xform *x);

#endif
