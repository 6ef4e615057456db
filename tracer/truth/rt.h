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
    /* An instanced scene (instancing.h): one BVH per prototype under an instance geometry per copy
     * (geomID = instance index; the mesh's own triangles are the geometry after them). A hit on a
     * copy reports hit.instID[0] = the instance and primID = the prototype's triangle; rt_surface
     * places the prototype's attributes as the copy's written-out form would have them. */
    RTCScene *protos;
    rt_vertex **proto_vertices; /* per prototype: its vertices' attributes, in its own space */
    int proto_count;
    RTCScene query;    /* point queries of an instanced scene (rt_build_queries), else NULL */
    long long bvh_live, bvh_peak; /* the memory monitor's running and peak sums */
    size_t bvh_bytes;      /* peak bytes Embree allocated (its memory monitor): BVHs and geometry buffers */
    double bvh_seconds;    /* rt_build's time: the BVHs and the shading attributes */
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

/* The shading every hit shares: ng the unit geometric normal toward the front, nsum the
 * interpolated (unnormalised) shading normal in world space, (w, u, v) the barycentrics on the
 * corners' colours and uvs. */
static inline void rt_shade(const scene *s, const material *mat, vec3 ng, vec3 nsum, const rt_vertex *v0,
                            const rt_vertex *v1, const rt_vertex *v2, float w, float u, float v, vec3 origin, vec3 dir,
                            float t, surface_hit *out)
{
    out->position = v3_madd(origin, dir, t);
    out->geometric_normal = ng;
    out->front_facing = v3_dot(ng, dir) < 0.0f;
    out->material = mat;
    out->shaded = out->front_facing || mat->double_sided;
    vec3 n = v3_normalize_or(nsum, ng);
    /* Keep the shading normal on the geometric side: interpolated normals can tip over at
     * silhouettes, which would shade a visible point as if facing away. */
    if (v3_dot(n, ng) < 0.0f)
        n = ng;
    if (!out->front_facing) /* seen from behind (double-sided): both normals face the viewer */
        n = v3_scale(n, -1.0f);
    out->normal = n;
    vec3 vc = v3(w * v0->color[0] + u * v1->color[0] + v * v2->color[0],
                 w * v0->color[1] + u * v1->color[1] + v * v2->color[1],
                 w * v0->color[2] + u * v1->color[2] + v * v2->color[2]);
    vec3 albedo = v3_mul(mat->color, vc);
    if ((s->effects & EFFECT_TEXTURES) && mat->texture >= 0) {
        float tu = w * v0->uv[0] + u * v1->uv[0] + v * v2->uv[0], tv = w * v0->uv[1] + u * v1->uv[1] + v * v2->uv[1];
        albedo = v3_mul(albedo, texture_lookup(&s->textures[mat->texture], tu, tv));
    }
    out->albedo = out->shaded ? albedo : v3(0, 0, 0);
}

static inline vec3 rt_interpolate_normal(const rt_vertex *v0, const rt_vertex *v1, const rt_vertex *v2, float w,
                                         float u, float v)
{
    return v3(w * v0->normal[0] + u * v1->normal[0] + v * v2->normal[0],
              w * v0->normal[1] + u * v1->normal[1] + v * v2->normal[1],
              w * v0->normal[2] + u * v1->normal[2] + v * v2->normal[2]);
}

#ifdef __cplusplus
extern "C" {
#endif
/* rt_surface's case of a hit on a copy (rt_instances.c). */
void rt_surface_instance(const rt_scene *rt, unsigned inst, unsigned prim, float u, float v, vec3 origin, vec3 dir,
                         float t, surface_hit *out);
#ifdef __cplusplus
}
#endif

/* Describes the hit of a ray with direction dir at barycentrics (u, v) on the mesh's triangle prim
 * (inst = RTC_INVALID_GEOMETRY_ID, what Embree reports outside instances) or on instance inst's
 * prototype triangle prim, with Embree's (u, v) in the prototype's winding. Inline: the ground
 * truth calls it for every sample and lets the compiler keep the result in registers. */
static inline void rt_surface(const rt_scene *rt, unsigned inst, unsigned prim, float u, float v, vec3 origin,
                              vec3 dir, float t, surface_hit *out)
{
    if (inst != RTC_INVALID_GEOMETRY_ID) {
        rt_surface_instance(rt, inst, prim, u, v, origin, dir, t, out);
        return;
    }
    const scene *s = rt->scene;
    const mesh *m = &s->mesh;
    const uint32_t *tri = &m->indices[3 * (size_t)prim];
    const rt_vertex *v0 = &rt->vertices[tri[0]], *v1 = &rt->vertices[tri[1]], *v2 = &rt->vertices[tri[2]];
    float w = 1.0f - u - v;
    rt_shade(s, &s->materials[m->materials[prim]], rt->face_normals[prim], rt_interpolate_normal(v0, v1, v2, w, u, v),
             v0, v1, v2, w, u, v, origin, dir, t, out);
}

#ifdef __cplusplus
extern "C" {
#endif

/* Embree over the scene; an instanced scene as Embree instances (the truth, the slicemaps, the
 * bake sampler's point queries). */
int rt_build(rt_scene *rt, const scene *s, vx_err *e);
void rt_free(rt_scene *rt);

#ifdef __cplusplus
}
#endif

#endif
