/* A mesh's shading attributes as rt_surface reads them (rt.h): per vertex (normal, colour, uv
 * interleaved), and the unit face normals toward each triangle's counter-clockwise front. For the
 * scene's mesh and for each instanced prototype. */
#ifndef VX_RT_ATTRIBUTES_H
#define VX_RT_ATTRIBUTES_H

#include "rt.h"

/* Allocates and fills *vertices, and *face_normals when face_normals is not NULL; -1 when out of
 * memory. */
int rt_mesh_attributes(const mesh *m, rt_vertex **vertices, vec3 **face_normals);

#endif
