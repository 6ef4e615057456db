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

#define XFORM_IDENTITY ((xform){{1, 1, 1}, {0, 0, 0}, {0, 0, 0}})

/* Reads {"scale": s | [x,y,z], "rotate_deg": [x,y,z], "translate": [x,y,z]} (each optional; no
 * other field) into *out; `where` names the object for messages. A zero scale is refused. */
int xform_parse(const cJSON *obj, const char *where, xform *out, vx_err *e);
/* Applies x to the vertices from v0 on; normals by the inverse transpose (renormalised), and the
 * winding of the triangles from t0 on reversed when the scale mirrors, to keep fronts outside. */
void xform_apply(mesh *m, size_t v0, size_t t0, const xform *x);
/* The same map as a row-major 3x4 matrix (p' = M[0..2] p + M[3] per row), in double. */
void xform_matrix(const xform *x, double M[12]);
/* 1 when the scale mirrors (its determinant is negative). */
int xform_mirrors(const xform *x);

#endif
