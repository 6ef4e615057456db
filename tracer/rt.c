#include "rt.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "shading.h"

static void embree_error(void *user, enum RTCError code, const char *str)
{
    (void)user;
    (void)code;
    (void)str; /* reported through rtcGetDeviceError where it matters */
}

int rt_build(rt_scene *rt, const scene *s, vx_err *e)
{
    memset(rt, 0, sizeof *rt);
    rt->scene = s;
    rt->device = rtcNewDevice(NULL);
    if (!rt->device)
        return vx_fail(e, "Embree: cannot create a device (error %d)", (int)rtcGetDeviceError(NULL));
    rtcSetDeviceErrorFunction(rt->device, embree_error, NULL);
    rt->bvh = rtcNewScene(rt->device);
    rtcSetSceneBuildQuality(rt->bvh, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry geom = rtcNewGeometry(rt->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    const mesh *m = &s->mesh;
    /* Embree's own buffers: it may read past the last vertex with 16-byte loads, which a shared
     * buffer of ours would have to be padded for. */
    float *vb = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                        m->vertex_count);
    unsigned *ib = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                           m->triangle_count);
    if (!vb || !ib) {
        rtcReleaseGeometry(geom);
        rt_free(rt);
        return vx_fail(e, "Embree: cannot allocate geometry buffers for %zu triangles", m->triangle_count);
    }
    memcpy(vb, m->positions, m->vertex_count * 3 * sizeof(float));
    memcpy(ib, m->indices, m->triangle_count * 3 * sizeof(unsigned));
    rtcCommitGeometry(geom);
    rtcAttachGeometry(rt->bvh, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(rt->bvh);
    if (rtcGetDeviceError(rt->device) != RTC_ERROR_NONE) {
        rt_free(rt);
        return vx_fail(e, "Embree: building the BVH failed");
    }
    rt->vertices = malloc(sizeof(rt_vertex) * (m->vertex_count ? m->vertex_count : 1));
    rt->face_normals = malloc(sizeof(vec3) * (m->triangle_count ? m->triangle_count : 1));
    if (!rt->vertices || !rt->face_normals) {
        rt_free(rt);
        return vx_fail(e, "out of memory for %zu vertices' shading attributes", m->vertex_count);
    }
    for (size_t i = 0; i < m->vertex_count; i++) {
        memcpy(rt->vertices[i].normal, &m->normals[3 * i], sizeof(float) * 3);
        memcpy(rt->vertices[i].color, &m->colors[3 * i], sizeof(float) * 3);
        memcpy(rt->vertices[i].uv, &m->uvs[2 * i], sizeof(float) * 2);
    }
    for (size_t t = 0; t < m->triangle_count; t++) {
        const uint32_t *tri = &m->indices[3 * t];
        vec3 a = mesh_position(m, tri[0]), b = mesh_position(m, tri[1]), c = mesh_position(m, tri[2]);
        rt->face_normals[t] = v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    }
    vec3 ext = v3_sub(s->bounds_hi, s->bounds_lo);
    float size = fmaxf(ext.x, fmaxf(ext.y, ext.z));
    float far = fmaxf(fmaxf(fabsf(s->bounds_lo.x), fabsf(s->bounds_hi.x)),
                      fmaxf(fmaxf(fabsf(s->bounds_lo.y), fabsf(s->bounds_hi.y)),
                            fmaxf(fabsf(s->bounds_lo.z), fabsf(s->bounds_hi.z))));
    /* Large enough to leave the surface at float precision far from the origin, small against the scene. */
    rt->epsilon = fmaxf(1e-5f * size, 4e-7f * far);
    return 0;
}

void rt_free(rt_scene *rt)
{
    if (rt->bvh)
        rtcReleaseScene(rt->bvh);
    if (rt->device)
        rtcReleaseDevice(rt->device);
    free(rt->vertices);
    free(rt->face_normals);
    rt->bvh = NULL;
    rt->device = NULL;
    rt->vertices = NULL;
    rt->face_normals = NULL;
}

void rt_surface(const rt_scene *rt, unsigned prim, float u, float v, vec3 origin, vec3 dir, float t,
                surface_hit *out)
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

vec3 rt_shade_light(const scene *s, const surface_hit *h, vec3 to_viewer, vec3 to_light, vec3 irradiance)
{
    if (!h->shaded)
        return v3(0, 0, 0);
    float cos_l = v3_dot(h->normal, to_light);
    /* A light below the geometric surface cannot reach it, whatever the shading normal says. */
    float side = v3_dot(h->front_facing ? h->geometric_normal : v3_scale(h->geometric_normal, -1.0f), to_light);
    if (cos_l <= 0.0f || side <= 0.0f)
        return v3(0, 0, 0);
    vec3 f = v3_scale(h->albedo, 1.0f / VX_PI);
    if (s->effects & EFFECT_SPECULAR) {
        float spec = shading_specular_brdf(h->normal, to_viewer, to_light, h->material->specular,
                                           h->material->roughness);
        f = v3_add(f, v3(spec, spec, spec));
    }
    return v3_scale(v3_mul(f, irradiance), cos_l);
}
