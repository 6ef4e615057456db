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
    /* An instanced scene (instancing.h) built by rt_build: one BVH per prototype under instance
     * geometries; Embree's filter turns every hit's primID into the scene mesh's triangle (the
     * copy's), so rt_surface and every caller see the expanded mesh's triangle numbers. */
    RTCScene *protos;
    int proto_count;
    int instanced;
    long long bvh_live, bvh_peak; /* the memory monitor's running and peak sums */
    size_t bvh_bytes;      /* peak bytes Embree allocated (its memory monitor): BVHs and geometry buffers */
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

/* Describes the hit of a ray with direction dir on triangle prim at barycentrics (u, v). Inline:
 * the ground truth calls it for every sample and lets the compiler keep the result in registers. */
static inline void rt_surface(const rt_scene *rt, unsigned prim, float u, float v, vec3 origin, vec3 dir,
                              float t, surface_hit *out)
{
    const scene *s = rt->scene;
    const mesh *m = &s->mesh;
    const uint32_t *tri = &m->indices[3 * (size_t)prim];
    const rt_vertex *v0 = &rt->vertices[tri[0]], *v1 = &rt->vertices[tri[1]], *v2 = &rt->vertices[tri[2]];
    float w = 1.0f - u - v;
    vec3 ng = rt->face_normals[prim];
    const material *mat = &s->materials[m->materials[prim]];
    out->position = v3_madd(origin, dir, t);
    out->geometric_normal = ng;
    out->front_facing = v3_dot(ng, dir) < 0.0f;
    out->material = mat;
    out->shaded = out->front_facing || mat->double_sided;
    vec3 n = v3_normalize_or(v3(w * v0->normal[0] + u * v1->normal[0] + v * v2->normal[0],
                                w * v0->normal[1] + u * v1->normal[1] + v * v2->normal[1],
                                w * v0->normal[2] + u * v1->normal[2] + v * v2->normal[2]),
                             ng);
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

#ifdef __cplusplus
extern "C" {
#endif

/* Embree over the scene; an instanced scene as Embree instances (the truth, the slicemaps). */
int rt_build(rt_scene *rt, const scene *s, vx_err *e);
/* One BVH over the scene's mesh with every instance written out: the bake sampler's point queries
 * walk it (the per-voxel own-triangle lists are those of the expanded scene). */
int rt_build_flat(rt_scene *rt, const scene *s, vx_err *e);
void rt_free(rt_scene *rt);

#ifdef __cplusplus
}
#endif

#endif
