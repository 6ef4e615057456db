/* Placement of objects and instances (xform.h). The arithmetic is the one scene.c always used for
 * "transform", kept in one place so instancing reproduces it exactly. */
#include "xform.h"

#include <math.h>
#include <string.h>

#include "json_util.h"

int xform_parse(const cJSON *xf, const char *where, xform *out, vx_err *e)
{
    static const char *const known[] = {"scale", "rotate_deg", "translate", NULL};
    *out = XFORM_IDENTITY;
    if (!cJSON_IsObject(xf))
        return vx_fail(e, "%s: expected an object {\"scale\", \"rotate_deg\", \"translate\"}", where);
    if (json_only_fields(xf, where, known, e))
        return -1;
    const cJSON *sc = cJSON_GetObjectItemCaseSensitive(xf, "scale");
    if (cJSON_IsNumber(sc)) {
        double k = 1;
        if (json_number(xf, "scale", where, &k, e))
            return -1;
        out->scale = v3((float)k, (float)k, (float)k);
    } else if (json_vec3(xf, "scale", where, &out->scale, e)) {
        return -1;
    }
    if (out->scale.x == 0 || out->scale.y == 0 || out->scale.z == 0)
        return vx_fail(e, "%s.scale: must not be zero", where);
    if (json_vec3(xf, "rotate_deg", where, &out->rotate_deg, e) || json_vec3(xf, "translate", where, &out->translate, e))
        return -1;
    return 0;
}

/* Rotates P and N (double) about x, then y, then z, by the angles whose cosines and sines are cs. */
static void rotate(const double cs[3][2], double P[3], double N[3])
{
    xform_rotate(cs, P);
    xform_rotate(cs, N);
}

void xform_prepare(const xform *x, xform_exact *out)
{
    out->scale = x->scale;
    out->translate = x->translate;
    double ang[3] = {x->rotate_deg.x * M_PI / 180, x->rotate_deg.y * M_PI / 180, x->rotate_deg.z * M_PI / 180};
    for (int a = 0; a < 3; a++)
        out->cs[a][0] = cos(ang[a]), out->cs[a][1] = sin(ang[a]);
}

void xform_normal(const xform_exact *x, const float n[3], float out[3])
{
    double P[3] = {0, 0, 0}, N[3] = {n[0] / x->scale.x, n[1] / x->scale.y, n[2] / x->scale.z};
    rotate(x->cs, P, N);
    /* A zero normal (a file's `vn 0 0 0`, a PLY's or glTF's zero normal) stays zero, so that the
     * shading falls back to the face's geometric normal (rt_shade) whether or not the object is
     * transformed; made +z, it lit a surface as if tangent to it. */
    vec3 nn = v3_normalize_or(v3((float)N[0], (float)N[1], (float)N[2]), v3(0.0f, 0.0f, 0.0f));
    out[0] = nn.x, out[1] = nn.y, out[2] = nn.z;
}

void xform_apply(mesh *m, size_t v0, size_t t0, const xform *x)
{
    xform_exact xe;
    xform_prepare(x, &xe);
    for (size_t i = v0; i < m->vertex_count; i++) {
        float *p = &m->positions[3 * i], *n = &m->normals[3 * i], q[3];
        xform_point(&xe, p, q);
        xform_normal(&xe, n, n);
        memcpy(p, q, sizeof q);
    }
    if (xform_mirrors(x))
        for (size_t t = t0; t < m->triangle_count; t++) {
            uint32_t tmp = m->indices[3 * t + 1];
            m->indices[3 * t + 1] = m->indices[3 * t + 2];
            m->indices[3 * t + 2] = tmp;
        }
}

void xform_matrix(const xform *x, double M[12])
{
    xform_exact xe;
    xform_prepare(x, &xe);
    const double s[3] = {x->scale.x, x->scale.y, x->scale.z}, t[3] = {x->translate.x, x->translate.y, x->translate.z};
    for (int c = 0; c < 3; c++) { /* column c: the image of the scaled unit vector e_c */
        double P[3] = {0, 0, 0}, N[3] = {0, 0, 0};
        P[c] = s[c];
        rotate(xe.cs, P, N);
        for (int r = 0; r < 3; r++)
            M[4 * r + c] = P[r];
    }
    for (int r = 0; r < 3; r++)
        M[4 * r + 3] = t[r];
}

int xform_mirrors(const xform *x) { return x->scale.x * x->scale.y * x->scale.z < 0; }
