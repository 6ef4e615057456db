#include "mesh.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void *grow(void *p, size_t count, size_t elem)
{
    void *q = realloc(p, count * elem);
    if (!q) {
        fprintf(stderr, "voxlab: out of memory building a mesh (%zu elements)\n", count);
        abort();
    }
    return q;
}

void mesh_free(mesh *m)
{
    free(m->positions);
    free(m->normals);
    free(m->uvs);
    free(m->colors);
    free(m->indices);
    free(m->materials);
    memset(m, 0, sizeof *m);
}

uint32_t mesh_add_vertex(mesh *m, vec3 p, vec3 n, float u, float v)
{
    if (m->vertex_count == m->vertex_capacity) {
        m->vertex_capacity = m->vertex_capacity ? m->vertex_capacity * 2 : 1024;
        m->positions = grow(m->positions, m->vertex_capacity * 3, sizeof(float));
        m->normals = grow(m->normals, m->vertex_capacity * 3, sizeof(float));
        m->uvs = grow(m->uvs, m->vertex_capacity * 2, sizeof(float));
        m->colors = grow(m->colors, m->vertex_capacity * 3, sizeof(float));
    }
    size_t i = m->vertex_count++;
    m->positions[3 * i + 0] = p.x;
    m->positions[3 * i + 1] = p.y;
    m->positions[3 * i + 2] = p.z;
    m->normals[3 * i + 0] = n.x;
    m->normals[3 * i + 1] = n.y;
    m->normals[3 * i + 2] = n.z;
    m->uvs[2 * i + 0] = u;
    m->uvs[2 * i + 1] = v;
    m->colors[3 * i + 0] = m->colors[3 * i + 1] = m->colors[3 * i + 2] = 1.0f;
    return (uint32_t)i;
}

void mesh_add_triangle(mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t material)
{
    if (m->triangle_count == m->triangle_capacity) {
        m->triangle_capacity = m->triangle_capacity ? m->triangle_capacity * 2 : 1024;
        m->indices = grow(m->indices, m->triangle_capacity * 3, sizeof(uint32_t));
        m->materials = grow(m->materials, m->triangle_capacity, sizeof(uint32_t));
    }
    size_t t = m->triangle_count++;
    m->indices[3 * t + 0] = a;
    m->indices[3 * t + 1] = b;
    m->indices[3 * t + 2] = c;
    m->materials[t] = material;
}

void mesh_add_flat_triangle(mesh *m, vec3 a, vec3 b, vec3 c, uint32_t material)
{
    vec3 n = v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    uint32_t i = mesh_add_vertex(m, a, n, 0, 0);
    mesh_add_vertex(m, b, n, 1, 0);
    mesh_add_vertex(m, c, n, 0, 1);
    mesh_add_triangle(m, i, i + 1, i + 2, material);
}

void mesh_add_quad(mesh *m, vec3 a, vec3 b, vec3 c, vec3 d, uint32_t material)
{
    vec3 n = v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    uint32_t i = mesh_add_vertex(m, a, n, 0, 0);
    mesh_add_vertex(m, b, n, 1, 0);
    mesh_add_vertex(m, c, n, 1, 1);
    mesh_add_vertex(m, d, n, 0, 1);
    mesh_add_triangle(m, i, i + 1, i + 2, material);
    mesh_add_triangle(m, i, i + 2, i + 3, material);
}

void mesh_add_box(mesh *m, vec3 lo, vec3 hi, uint32_t material)
{
    vec3 p[8];
    for (int k = 0; k < 8; k++)
        p[k] = v3(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
    /* Corners indexed by bits (x, y, z); each face listed counter-clockwise seen from outside. */
    static const int faces[6][4] = {
        {0, 4, 6, 2}, /* -x */
        {1, 3, 7, 5}, /* +x */
        {0, 1, 5, 4}, /* -y */
        {2, 6, 7, 3}, /* +y */
        {0, 2, 3, 1}, /* -z */
        {4, 5, 7, 6}, /* +z */
    };
    for (int f = 0; f < 6; f++)
        mesh_add_quad(m, p[faces[f][0]], p[faces[f][1]], p[faces[f][2]], p[faces[f][3]], material);
}

vec3 mesh_position(const mesh *m, uint32_t i)
{
    return v3(m->positions[3 * i], m->positions[3 * i + 1], m->positions[3 * i + 2]);
}

void mesh_smooth_normals(mesh *m, size_t first_vertex, size_t first_triangle)
{
    m->normals_smoothed = 1;
    for (size_t i = first_vertex; i < m->vertex_count; i++)
        m->normals[3 * i] = m->normals[3 * i + 1] = m->normals[3 * i + 2] = 0.0f;
    for (size_t t = first_triangle; t < m->triangle_count; t++) {
        const uint32_t *tri = &m->indices[3 * t];
        vec3 a = mesh_position(m, tri[0]), b = mesh_position(m, tri[1]), c = mesh_position(m, tri[2]);
        /* The unnormalised cross product is twice the area times the normal: area weighting for free. */
        vec3 n = v3_cross(v3_sub(b, a), v3_sub(c, a));
        for (int k = 0; k < 3; k++) {
            float *dst = &m->normals[3 * tri[k]];
            dst[0] += n.x;
            dst[1] += n.y;
            dst[2] += n.z;
        }
    }
    for (size_t i = first_vertex; i < m->vertex_count; i++) {
        vec3 n = v3_normalize(v3(m->normals[3 * i], m->normals[3 * i + 1], m->normals[3 * i + 2]));
        m->normals[3 * i] = n.x;
        m->normals[3 * i + 1] = n.y;
        m->normals[3 * i + 2] = n.z;
    }
}

void mesh_flat_normals(mesh *m, size_t v0, size_t t0)
{
    size_t nv = m->vertex_count - v0, nt = m->triangle_count - t0;
    if (nv == 0)
        return; /* no vertices, no triangles (and a mesh's arrays may still be NULL) */
    /* The corners' attributes are read from a copy: the new vertices overwrite the old ones' slots
     * (vertex v0 + 3 t + k is corner k of triangle t0 + t). */
    float *pos = grow(NULL, 8 * nv, sizeof *pos), *uv = pos + 3 * nv, *col = uv + 2 * nv;
    memcpy(pos, m->positions + 3 * v0, 3 * nv * sizeof *pos);
    memcpy(uv, m->uvs + 2 * v0, 2 * nv * sizeof *uv);
    memcpy(col, m->colors + 3 * v0, 3 * nv * sizeof *col);
    m->vertex_count = v0;
    for (size_t t = t0; t < t0 + nt; t++) {
        uint32_t *tri = &m->indices[3 * t];
        const float *p[3];
        for (int k = 0; k < 3; k++)
            p[k] = pos + 3 * (tri[k] - v0);
        vec3 a = v3(p[0][0], p[0][1], p[0][2]), b = v3(p[1][0], p[1][1], p[1][2]), c = v3(p[2][0], p[2][1], p[2][2]);
        /* As mesh_add_flat_triangle; a zero-area triangle gets +z as mesh_smooth_normals gives its
         * lone vertices (the scene drops it, drop_degenerate). */
        vec3 n = v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
        for (int k = 0; k < 3; k++) {
            size_t old = tri[k] - v0;
            uint32_t idx = mesh_add_vertex(m, v3(p[k][0], p[k][1], p[k][2]), n, uv[2 * old], uv[2 * old + 1]);
            mesh_set_vertex_color(m, idx, v3(col[3 * old], col[3 * old + 1], col[3 * old + 2]));
            tri[k] = idx;
        }
    }
    free(pos);
}

/* A vertex shared by more triangles than this whose normals do not all lie within half the crease
 * of their mean (a cone's apex) gives each corner its own triangle's normal: grouping its corners
 * by shared edges is quadratic in the triangles around it. */
#define CREASE_MAX_PAIRWISE 4096

static int is_zero(vec3 u) { return u.x == 0.0f && u.y == 0.0f && u.z == 0.0f; }

/* Whether every triangle around a vertex lies within half the crease of their mean direction, so
 * that every pair lies within the crease (the common smooth case: one group, no pairwise test). */
static int all_within(const vec3 *unit, const uint32_t *corners, size_t n, float cos_half)
{
    vec3 mean = v3(0.0f, 0.0f, 0.0f);
    for (size_t i = 0; i < n; i++)
        mean = v3_add(mean, unit[corners[i] / 3]);
    mean = v3_normalize_or(mean, v3(0.0f, 0.0f, 0.0f));
    for (size_t i = 0; i < n; i++) {
        vec3 u = unit[corners[i] / 3];
        if (!is_zero(u) && !(v3_dot(u, mean) >= cos_half))
            return 0;
    }
    return 1;
}

static size_t group_root(size_t *parent, size_t i)
{
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

/* Whether triangles a and b (mesh-local numbers) share an edge through vertex v: another vertex. */
static int share_edge(const uint32_t *indices, size_t a, size_t b, uint32_t v)
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            if (indices[3 * a + (size_t)i] != v && indices[3 * a + (size_t)i] == indices[3 * b + (size_t)j])
                return 1;
    return 0;
}

void mesh_crease_normals(mesh *m, size_t v0, size_t t0, float crease_deg)
{
    size_t nv = m->vertex_count - v0, nt = m->triangle_count - t0;
    if (nt == 0)
        return;
    const double radians = 3.14159265358979323846 / 180.0;
    float cos_crease = (float)cos(crease_deg * radians), cos_half = (float)cos(0.5 * crease_deg * radians);
    vec3 *face = grow(NULL, 2 * nt, sizeof *face), *unit = face + nt; /* cross products, and unit */
    size_t *start = grow(NULL, nv + 1, sizeof *start);
    uint32_t *corners = grow(NULL, 3 * nt, sizeof *corners); /* corner 3 t + k, by vertex */
    const uint32_t *tri_of = m->indices + 3 * t0;            /* the object's triangles */
    memset(start, 0, (nv + 1) * sizeof *start);
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *tri = &tri_of[3 * t];
        vec3 a = mesh_position(m, tri[0]), b = mesh_position(m, tri[1]), c = mesh_position(m, tri[2]);
        face[t] = v3_cross(v3_sub(b, a), v3_sub(c, a)); /* twice the area times the normal */
        unit[t] = v3_normalize_or(face[t], v3(0.0f, 0.0f, 0.0f));
        for (int k = 0; k < 3; k++)
            start[tri[k] - v0 + 1]++;
    }
    for (size_t v = 0; v < nv; v++)
        start[v + 1] += start[v];
    size_t *fill = grow(NULL, nv, sizeof *fill);
    memcpy(fill, start, nv * sizeof *fill);
    for (size_t t = 0; t < nt; t++)
        for (int k = 0; k < 3; k++)
            corners[fill[tri_of[3 * t + (size_t)k] - v0]++] = (uint32_t)(3 * t + (size_t)k);
    free(fill);
    size_t cap = 0, *parent = NULL;
    vec3 *sum = NULL; /* per group (indexed by its root corner) */
    uint32_t *carrier = NULL; /* the vertex that carries each group's normal; UINT32_MAX: none yet */
    for (size_t v = 0; v < nv; v++) {
        const uint32_t *c = corners + start[v];
        size_t n = start[v + 1] - start[v];
        if (n == 0)
            continue;
        if (n > cap) {
            cap = n;
            parent = grow(parent, cap, sizeof *parent);
            sum = grow(sum, cap, sizeof *sum);
            carrier = grow(carrier, cap, sizeof *carrier);
        }
        /* The corners' groups: around the vertex, two triangles that share an edge and lie within
         * the crease of each other are one smooth surface (an edge-based crease, as a modeller's
         * smoothing angle: an icosahedron's 42-degree edges join its five faces around a corner
         * though the faces across the corner lie 64 degrees apart). */
        uint32_t vertex = (uint32_t)(v0 + v);
        int one = all_within(unit, c, n, cos_half), flat = !one && n > CREASE_MAX_PAIRWISE;
        for (size_t i = 0; i < n; i++)
            parent[i] = one ? 0 : i;
        for (size_t i = 0; !one && !flat && i < n; i++)
            for (size_t j = i + 1; j < n; j++) {
                size_t ti = c[i] / 3, tj = c[j] / 3;
                if ((is_zero(unit[ti]) || is_zero(unit[tj]) || v3_dot(unit[ti], unit[tj]) >= cos_crease) &&
                    share_edge(tri_of, ti, tj, vertex)) {
                    size_t ri = group_root(parent, i), rj = group_root(parent, j);
                    parent[ri > rj ? ri : rj] = ri < rj ? ri : rj; /* the earlier corner is the root */
                }
            }
        for (size_t i = 0; i < n; i++) {
            sum[i] = v3(0.0f, 0.0f, 0.0f);
            carrier[i] = UINT32_MAX;
        }
        for (size_t i = 0; i < n; i++) {
            size_t r = group_root(parent, i);
            sum[r] = v3_add(sum[r], face[c[i] / 3]);
        }
        /* The first group (in triangle order) keeps the vertex, every other one gets a copy. */
        int first = 1;
        for (size_t i = 0; i < n; i++) {
            size_t r = group_root(parent, i);
            if (carrier[r] == UINT32_MAX) {
                vec3 nrm = v3_normalize(sum[r]);
                uint32_t idx = vertex;
                if (!first) {
                    vec3 col = v3(m->colors[3 * idx], m->colors[3 * idx + 1], m->colors[3 * idx + 2]);
                    idx = mesh_add_vertex(m, mesh_position(m, vertex), nrm, m->uvs[2 * vertex], m->uvs[2 * vertex + 1]);
                    mesh_set_vertex_color(m, idx, col); /* (only the vertex arrays grow: tri_of stays) */
                }
                m->normals[3 * idx] = nrm.x, m->normals[3 * idx + 1] = nrm.y, m->normals[3 * idx + 2] = nrm.z;
                carrier[r] = idx;
                first = 0;
            }
            m->indices[3 * t0 + c[i]] = carrier[r];
        }
    }
    free(parent);
    free(sum);
    free(carrier);
    free(corners);
    free(start);
    free(face);
}

void mesh_set_vertex_color(mesh *m, uint32_t i, vec3 c)
{
    m->colors[3 * i + 0] = c.x;
    m->colors[3 * i + 1] = c.y;
    m->colors[3 * i + 2] = c.z;
}
