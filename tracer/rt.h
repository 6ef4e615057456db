/* The scene's triangles in an Embree 3 BVH, and what a hit means: position, normals, colour. Used by
 * the ground truth and the bake sampler, so both see exactly the same surfaces. */
#ifndef VX_RT_H
#define VX_RT_H

#include <embree3/rtcore.h>

#include "scene.h"

/* Per-vertex shading attributes interleaved (32 bytes): a hit reads one cache line per vertex
 * instead of one per attribute array, which matters for the ground truth's ray rate. */
typedef struct {
    float normal[3];
    float color[3];
    float uv[2];
} rt_vertex;

typedef struct {
    RTCDevice device;
    RTCScene bvh;
    const scene *scene;
    float epsilon;         /* offset for secondary rays, relative to the scene's size */
    rt_vertex *vertices;   /* per vertex */
    vec3 *face_normals;    /* per triangle: unit, toward the counter-clockwise front */
} rt_scene;

typedef struct {
    vec3 position;
    vec3 normal;           /* shading normal, on the side the ray came from when double-sided */
    vec3 geometric_normal; /* unit, pointing to the triangle's front (counter-clockwise) side */
    int front_facing;      /* the ray hit the front side */
    int shaded;            /* 0 for the back of a single-sided surface: a black occluder */
    vec3 albedo;           /* material colour x vertex colour x texture (when declared) */
    const material *material;
} surface_hit;

/* Lane k of an Embree ray packet: origin, direction and interval [tnear, tfar]; every other field
 * at its neutral value. The ray of a RTCRayHit16 also gets an invalid hit. */
static inline void rt_packet_ray(struct RTCRay16 *r, int k, vec3 org, vec3 dir, float tnear, float tfar)
{
    r->org_x[k] = org.x, r->org_y[k] = org.y, r->org_z[k] = org.z;
    r->dir_x[k] = dir.x, r->dir_y[k] = dir.y, r->dir_z[k] = dir.z;
    r->tnear[k] = tnear;
    r->tfar[k] = tfar;
    r->time[k] = 0.0f;
    r->mask[k] = 0xffffffffu;
    r->id[k] = (unsigned)k;
    r->flags[k] = 0;
}

static inline void rt_packet_rayhit(struct RTCRayHit16 *rh, int k, vec3 org, vec3 dir, float tnear, float tfar)
{
    rt_packet_ray(&rh->ray, k, org, dir, tnear, tfar);
    rh->hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
}

#ifdef __cplusplus
extern "C" {
#endif

int rt_build(rt_scene *rt, const scene *s, vx_err *e);
void rt_free(rt_scene *rt);

/* Describes the hit of a ray with direction dir on triangle prim at barycentrics (u, v). */
void rt_surface(const rt_scene *rt, unsigned prim, float u, float v, vec3 origin, vec3 dir, float t,
                surface_hit *out);

/* Outgoing radiance toward `to_viewer` from light li arriving along to_light with irradiance E:
 * Lambert plus, when the scene declares "specular", the Beckmann lobe. */
vec3 rt_shade_light(const scene *s, const surface_hit *h, vec3 to_viewer, vec3 to_light, vec3 irradiance);

#ifdef __cplusplus
}
#endif

#endif
