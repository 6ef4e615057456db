/* Placement of objects and instances (xform.h). The arithmetic is the one scene.c always used for
 * "transform", kept in one place so instancing reproduces it exactly. */
#include "xform.h"

#include <math.h>

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

/* Rotates P and N (double) about x, then y, then z. */
static void rotate(const double ang[3], double P[3], double N[3])
{
    for (int axis = 0; axis < 3; axis++) {
        int a = (axis + 1) % 3, b = (axis + 2) % 3;
        double c = cos(ang[axis]), s = sin(ang[axis]);
        double pa = c * P[a] - s * P[b], pb = s * P[a] + c * P[b];
        double na = c * N[a] - s * N[b], nb = s * N[a] + c * N[b];
        P[a] = pa, P[b] = pb, N[a] = na, N[b] = nb;
    }
}

void xform_apply(mesh *m, size_t v0, size_t t0, const xform *x)
{
    vec3 scale = x->scale, rot = x->rotate_deg, tr = x->translate;
    double ang[3] = {rot.x * M_PI / 180, rot.y * M_PI / 180, rot.z * M_PI / 180};
    for (size_t i = v0; i < m->vertex_count; i++) {
        float *p = &m->positions[3 * i], *n = &m->normals[3 * i];
        double P[3] = {p[0] * scale.x, p[1] * scale.y, p[2] * scale.z};
        double N[3] = {n[0] / scale.x, n[1] / scale.y, n[2] / scale.z};
        rotate(ang, P, N);
        vec3 nn = v3_normalize(v3((float)N[0], (float)N[1], (float)N[2]));
        p[0] = (float)(P[0] + tr.x), p[1] = (float)(P[1] + tr.y), p[2] = (float)(P[2] + tr.z);
        n[0] = nn.x, n[1] = nn.y, n[2] = nn.z;
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
    double ang[3] = {x->rotate_deg.x * M_PI / 180, x->rotate_deg.y * M_PI / 180, x->rotate_deg.z * M_PI / 180};
    const double s[3] = {x->scale.x, x->scale.y, x->scale.z}, t[3] = {x->translate.x, x->translate.y, x->translate.z};
    for (int c = 0; c < 3; c++) { /* column c: the image of the scaled unit vector e_c */
        double P[3] = {0, 0, 0}, N[3] = {0, 0, 0};
        P[c] = s[c];
        rotate(ang, P, N);
        for (int r = 0; r < 3; r++)
            M[4 * r + c] = P[r];
    }
    for (int r = 0; r < 3; r++)
        M[4 * r + 3] = t[r];
}

int xform_mirrors(const xform *x) { return x->scale.x * x->scale.y * x->scale.z < 0; }
