/* The Embree side of instancing (tracer/scene/instancing.h): a BVH per prototype, an instance
 * geometry per copy (geomID = instance index), and the scene mesh (the objects drawn once) as the
 * geometry after them. */
#ifndef VX_RT_INSTANCES_H
#define VX_RT_INSTANCES_H

#include "rt.h"

/* Attaches the instanced scene's geometry to rt->bvh (not yet committed); rt->protos filled. */
int rt_attach_instances(rt_scene *rt, const scene *s, vx_err *e);
/* A committed triangle geometry holding mesh m (every BVH of rt.c is made of these). */
RTCGeometry rt_triangle_geometry(RTCDevice device, const mesh *m);

/* Every triangle whose bounds come near the sphere (centre, radius), a copy's included, visited
 * as visit(user, inst, prim): inst = RTC_INVALID_GEOMETRY_ID and prim the mesh's triangle, or the
 * copy and its prototype's triangle (rt_surface's arguments). Conservative: it may visit more. */
typedef void (*rt_triangle_visit)(void *user, unsigned inst, unsigned prim);
void rt_query_sphere(const rt_scene *rt, const float centre[3], float radius, rt_triangle_visit visit, void *user);
/* The instanced scene's query structure (nothing for a scene without instances); rt_build calls it. */
int rt_build_queries(rt_scene *rt, vx_err *e);

#endif
