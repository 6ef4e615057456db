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

#endif
