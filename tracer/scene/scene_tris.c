/* A scene's triangles, instance copies placed on the fly (scene_tris.h). */
#include "scene_tris.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

size_t scene_triangle_count(const scene *s) { return s->mesh.triangle_count + (s->inst ? s->inst->triangles : 0); }

void inst_corners(const scene_instancing *in, const inst_instance *I, uint32_t p, float out[9])
{
    const mesh *m = &in->protos[I->proto];
    const uint32_t *x = &m->indices[3 * (size_t)p];
    static const int mirrored[3] = {0, 2, 1};
    for (int k = 0; k < 3; k++)
        xform_point(&I->x, &m->positions[3 * (size_t)x[I->mirror ? mirrored[k] : k]], &out[3 * k]);
}

const inst_instance *scene_triangle_instance(const scene *s, size_t t, uint32_t *proto_triangle)
{
    const scene_instancing *in = s->inst;
    size_t c = t - s->mesh.triangle_count, lo = 0, hi = in->count - 1;
    while (lo < hi) { /* the last instance whose offset is <= c */
        size_t mid = (lo + hi + 1) / 2;
        if (in->inst[mid].offset <= c)
            lo = mid;
        else
            hi = mid - 1;
    }
    *proto_triangle = (uint32_t)(c - in->inst[lo].offset);
    return &in->inst[lo];
}

void scene_triangle_corners(const scene *s, size_t first, size_t count, float (*out)[9])
{
    const mesh *m = &s->mesh;
    size_t t = first, end = first + count;
    for (; t < end && t < m->triangle_count; t++)
        for (int k = 0; k < 3; k++)
            memcpy(&out[t - first][3 * k], &m->positions[3 * (size_t)m->indices[3 * t + (size_t)k]], 3 * sizeof(float));
    if (t >= end)
        return;
    uint32_t p;
    const inst_instance *I = scene_triangle_instance(s, t, &p);
    const scene_instancing *in = s->inst;
    for (; t < end; t++) {
        if (p == in->protos[I->proto].triangle_count) /* on to the next copy */
            I++, p = 0;
        inst_corners(in, I, p++, out[t - first]);
    }
}

uint32_t scene_hit_material(const scene *s, unsigned inst, unsigned prim)
{
    if (inst == UINT32_MAX || !s->inst)
        return s->mesh.materials[prim];
    return s->inst->protos[s->inst->inst[inst].proto].materials[prim];
}

/* Plain comparisons, inlined (libm's fmin/fmax are calls, for NaN rules; coordinates are finite). */
static inline void grow(double lo[3], double hi[3], const float p[3])
{
    for (int a = 0; a < 3; a++) {
        lo[a] = p[a] < lo[a] ? p[a] : lo[a];
        hi[a] = p[a] > hi[a] ? p[a] : hi[a];
    }
}

int inst_compute_bounds(scene *s, vx_err *e)
{
    scene_instancing *in = s->inst;
    for (int a = 0; a < 3; a++)
        in->lo[a] = INFINITY, in->hi[a] = -INFINITY;
    /* Each prototype's vertices that its triangles use, placed once per copy (not per corner). */
    for (int q = 0; q < in->proto_count; q++) {
        const mesh *pm = &in->protos[q];
        unsigned char *used = calloc(pm->vertex_count + 1, 1);
        uint32_t *list = malloc((pm->vertex_count + 1) * sizeof *list);
        if (!used || !list) {
            free(used), free(list);
            return vx_fail(e, "%s: out of memory", s->path);
        }
        size_t n = 0;
        for (size_t i = 0; i < 3 * pm->triangle_count; i++)
            if (!used[pm->indices[i]]) {
                used[pm->indices[i]] = 1;
                list[n++] = pm->indices[i];
            }
        free(used);
        for (size_t i = 0; i < in->count; i++) {
            inst_instance *I = &in->inst[i];
            if (I->proto != q)
                continue;
            double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
            for (size_t v = 0; v < n; v++) {
                float w[3];
                xform_point(&I->x, &pm->positions[3 * (size_t)list[v]], w);
                grow(lo, hi, w);
            }
            /* A non-finite corner (a scale overflowing float) shows in the copy's bounds. */
            for (int a = 0; a < 3; a++)
                if (!isfinite(lo[a]) || !isfinite(hi[a])) {
                    free(list);
                    return vx_fail(e, "%s: instance %zu places a vertex of its object at a non-finite position", s->path, i);
                }
            for (int a = 0; a < 3; a++) /* float values: they are placed corners' coordinates */
                I->lo[a] = (float)lo[a], I->hi[a] = (float)hi[a];
            grow(in->lo, in->hi, I->lo);
            grow(in->lo, in->hi, I->hi);
        }
        free(list);
    }
    return 0;
}

void scene_triangle_bounds(const scene *s, double lo[3], double hi[3])
{
    for (int a = 0; a < 3; a++)
        lo[a] = INFINITY, hi[a] = -INFINITY;
    const mesh *m = &s->mesh;
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int k = 0; k < 3; k++)
            grow(lo, hi, &m->positions[3 * (size_t)m->indices[3 * t + (size_t)k]]);
    if (s->inst && s->inst->count)
        for (int a = 0; a < 3; a++)
            lo[a] = vx_fmin(lo[a], s->inst->lo[a]), hi[a] = vx_fmax(hi[a], s->inst->hi[a]);
}
