/* The Embree side of instancing (tracer/scene/instancing.h): a BVH per prototype, an instance
 * geometry per copy, and the triangles of the other objects in one geometry of their own; filter
 * functions renumber each hit to the scene mesh's triangle, so shading reads the expanded mesh's
 * attributes (the material, normals and colour of the copy the ray met). */
#ifndef VX_RT_INSTANCES_H
#define VX_RT_INSTANCES_H

#include "rt.h"

/* Attaches the instanced scene's geometry to rt->bvh (not yet committed); rt->protos filled. */
int rt_attach_instances(rt_scene *rt, const scene *s, vx_err *e);
/* A committed triangle geometry holding mesh m (every BVH of rt.c is made of these). */
RTCGeometry rt_triangle_geometry(RTCDevice device, const mesh *m);

#endif
