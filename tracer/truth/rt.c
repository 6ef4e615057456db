#include "rt.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

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
