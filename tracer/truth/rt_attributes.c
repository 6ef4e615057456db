/* Shading attributes of a mesh as rt_surface reads them (rt_attributes.h). */
#include "rt_attributes.h"

#include <stdlib.h>
#include <string.h>

int rt_mesh_attributes(const mesh *m, rt_vertex **vertices, vec3 **face_normals)
{
    *vertices = malloc(sizeof(rt_vertex) * (m->vertex_count ? m->vertex_count : 1));
    if (face_normals)
        *face_normals = malloc(sizeof(vec3) * (m->triangle_count ? m->triangle_count : 1));
    if (!*vertices || (face_normals && !*face_normals))
        return -1;
    for (size_t i = 0; i < m->vertex_count; i++) {
        memcpy((*vertices)[i].normal, &m->normals[3 * i], sizeof(float) * 3);
        memcpy((*vertices)[i].color, &m->colors[3 * i], sizeof(float) * 3);
        memcpy((*vertices)[i].uv, &m->uvs[2 * i], sizeof(float) * 2);
    }
    for (size_t t = 0; face_normals && t < m->triangle_count; t++) {
        const uint32_t *tri = &m->indices[3 * t];
        vec3 a = mesh_position(m, tri[0]), b = mesh_position(m, tri[1]), c = mesh_position(m, tri[2]);
        (*face_normals)[t] = v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    }
    return 0;
}
