/* One light's map while it is built (shadow_build_internal.h): its light-space frame, orthographic
 * for a directional light and a perspective frustum around the scene for a point light (Eisemann &
 * Décoret §2.1: "a camera placed outside the zone of interest"), its column rays, and the step that
 * turns a column's transmittance profile into bits and T values. Shared by the builders
 * (slicemap_triangles.c, slicemap_model.c) and the packing (shadow_build.c). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "shadow_build_internal.h"

/* A unit vector perpendicular to w: the cross product with the axis least aligned with w. */
static vec3 perpendicular(vec3 w)
{
    vec3 a = fabsf(w.x) <= fabsf(w.y) && fabsf(w.x) <= fabsf(w.z) ? v3(1, 0, 0)
             : fabsf(w.y) <= fabsf(w.z)                           ? v3(0, 1, 0)
                                                                  : v3(0, 0, 1);
    return v3_normalize(v3_cross(w, a));
}

/* The padded bounds the frame is built around (shadow_frame), and their diagonal. */
static float padded_bounds(const scene *s, vec3 *lo, vec3 *hi)
{
    *lo = s->bounds_lo, *hi = s->bounds_hi;
    float diag = v3_length(v3_sub(*hi, *lo));
    float pad = 1e-3f * diag + 1e-6f;
    *lo = v3_sub(*lo, v3(pad, pad, pad));
    *hi = v3_add(*hi, v3(pad, pad, pad));
    return v3_length(v3_sub(*hi, *lo));
}

int shadow_point_light_refused(const scene *s, const light *L, int li, vx_err *e)
{
    vec3 lo, hi;
    float diag = padded_bounds(s, &lo, &hi);
    vec3 centre = v3_scale(v3_add(lo, hi), 0.5f);
    float radius = 0.5f * diag, dist = v3_length(v3_sub(centre, L->position));
    if (!(dist > 1.001f * radius))
        return vx_fail(e, "%s: lights[%d]: a point light inside the scene's bounding sphere needs a cube of six "
                          "shadow maps, which slicemap shadows do not have (a perspective frustum only); use "
                          "--shadows march",
                       s->path, li);
    return 0;
}

int shadow_frame(const scene *s, const light *L, int li, int res, int has_opaque, map_build *b, vx_err *e)
{
    memset(b, 0, sizeof *b);
    shadow_map_params *m = &b->m;
    vec3 lo, hi;
    float diag = padded_bounds(s, &lo, &hi);
    m->type = L->type;
    m->res = res;
    m->words = (res + 63) / 64;
    m->slices = 64 * m->words;
    m->has_opaque = has_opaque;
    double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY, wmin = INFINITY, wmax = -INFINITY;
    if (L->type == LIGHT_DIRECTIONAL) {
        m->w = v3_scale(L->direction, -1.0f); /* the light travels along -direction */
        m->u = perpendicular(m->w);
        m->v = v3_cross(m->w, m->u);
        for (int c = 0; c < 8; c++) {
            vec3 p = v3(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z);
            double u = v3_dot(p, m->u), v = v3_dot(p, m->v), w = v3_dot(p, m->w);
            umin = vx_fmin(umin, u), umax = vx_fmax(umax, u);
            vmin = vx_fmin(vmin, v), vmax = vx_fmax(vmax, v);
            wmin = vx_fmin(wmin, w), wmax = vx_fmax(wmax, w);
        }
    } else {
        vec3 centre = v3_scale(v3_add(lo, hi), 0.5f);
        float radius = 0.5f * diag, dist = v3_length(v3_sub(centre, L->position));
        if (shadow_point_light_refused(s, L, li, e))
            return -1;
        m->origin = L->position;
        m->w = v3_scale(v3_sub(centre, L->position), 1.0f / dist);
        m->u = perpendicular(m->w);
        m->v = v3_cross(m->w, m->u);
        double tan_half = radius / sqrt((double)dist * dist - (double)radius * radius);
        umin = vmin = -tan_half;
        umax = vmax = tan_half;
        wmin = dist - radius;
        wmax = dist + radius;
    }
    double min_extent = 1e-6 * diag;
    b->du = vx_fmax(umax - umin, min_extent) / res;
    b->dv = vx_fmax(vmax - vmin, min_extent) / res;
    b->len = (float)vx_fmax(wmax - wmin, min_extent);
    m->u0 = (float)umin;
    m->v0 = (float)vmin;
    m->inv_du = (float)(1.0 / b->du);
    m->inv_dv = (float)(1.0 / b->dv);
    m->w0 = (float)wmin;
    m->inv_dw = (float)m->slices / b->len;
    double across = vx_fmax(b->du, b->dv) * (L->type == LIGHT_POINT ? wmax : 1.0);
    /* The opaque map's depth is the surface's at the column's centre: a surface tilted against the
     * light differs across the column by up to its width, hence 1.5 cells. The transmitting cells
     * need only their own slice (the caller's skip keeps a surface from shadowing itself). */
    double slice = (double)b->len / m->slices;
    m->bias = (float)(has_opaque ? 1.5 * vx_fmax(across, slice) : slice);
    size_t cols = (size_t)res * (size_t)res;
    b->bits = calloc(cols * (size_t)m->words, sizeof *b->bits);
    b->opaque = has_opaque ? malloc(cols * sizeof *b->opaque) : NULL;
    b->row_T = calloc((size_t)res, sizeof *b->row_T);
    b->row_n = calloc((size_t)res, sizeof *b->row_n);
    b->row_cap = calloc((size_t)res, sizeof *b->row_cap);
    if (!b->bits || (has_opaque && !b->opaque) || !b->row_T || !b->row_n || !b->row_cap) {
        map_build_free(b);
        return vx_fail(e, "out of memory for a %dx%dx%d shadow map", res, res, m->slices);
    }
    for (size_t c = 0; has_opaque && c < cols; c++)
        b->opaque[c] = INFINITY;
    return 0;
}

void map_build_free(map_build *b)
{
    for (int j = 0; b->row_T && j < b->m.res; j++)
        free(b->row_T[j]);
    free(b->row_T);
    free(b->row_n);
    free(b->row_cap);
    free(b->bits);
    free(b->opaque);
    memset(b, 0, sizeof *b);
}

void shadow_column_ray(const map_build *b, int i, int j, int from_far, vec3 *org, vec3 *dir)
{
    const shadow_map_params *m = &b->m;
    double a = m->u0 + (i + 0.5) * b->du, c = m->v0 + (j + 0.5) * b->dv;
    if (m->type == LIGHT_POINT) {
        vec3 d = v3_normalize(v3_add(m->w, v3_add(v3_scale(m->u, (float)a), v3_scale(m->v, (float)c))));
        float t = from_far ? m->w0 + b->len : m->w0;
        *org = v3_madd(m->origin, d, t);
        *dir = from_far ? v3_scale(d, -1.0f) : d;
        return;
    }
    vec3 p = v3_add(v3_scale(m->u, (float)a), v3_scale(m->v, (float)c));
    *org = v3_madd(p, m->w, from_far ? m->w0 + b->len : m->w0);
    *dir = from_far ? v3_scale(m->w, -1.0f) : m->w;
}

float shadow_column_radius(const map_build *b, float d)
{
    double r = 0.5 * vx_fmax(b->du, b->dv);
    return (float)(b->m.type == LIGHT_POINT ? r * (b->m.w0 + d) : r);
}

int shadow_slice(const map_build *b, float d)
{
    float f = floorf(d * b->m.inv_dw);
    return f < 0.0f ? 0 : f >= (float)b->m.slices ? b->m.slices - 1 : (int)f;
}

void shadow_column_finish(map_build *b, int i, int j, const float *cum)
{
    const shadow_map_params *m = &b->m;
    uint64_t *w = &b->bits[((size_t)j * (size_t)m->res + (size_t)i) * (size_t)m->words];
    float prev = 1.0f;
    for (int k = 0; k < m->slices; k++) {
        if (!(cum[k] < prev))
            continue;
        prev = cum[k];
        if (b->row_n[j] == b->row_cap[j]) {
            size_t cap = b->row_cap[j] ? 2 * b->row_cap[j] : 256;
            float *grown = realloc(b->row_T[j], cap * sizeof *grown);
            if (!grown) {
                b->failed = 1;
                return;
            }
            b->row_T[j] = grown;
            b->row_cap[j] = cap;
        }
        b->row_T[j][b->row_n[j]++] = prev;
        w[k >> 6] |= ((uint64_t)1) << (k & 63);
    }
}
