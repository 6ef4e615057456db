#include "mesh.h"

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

void mesh_set_vertex_color(mesh *m, uint32_t i, vec3 c)
{
    m->colors[3 * i + 0] = c.x;
    m->colors[3 * i + 1] = c.y;
    m->colors[3 * i + 2] = c.z;
}
