#include "rt.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "instancing.h"
#include "rt_instances.h"

static void embree_error(void *user, enum RTCError code, const char *str)
{
    (void)user;
    (void)code;
    (void)str; /* reported through rtcGetDeviceError where it matters */
}

/* Embree's memory monitor: every allocation of the device (BVH nodes, primitive blocks, our
 * geometry buffers), so that an instanced scene's BVH memory can be set beside its expanded form's. */
static bool memory_monitor(void *user, ssize_t bytes, bool post)
{
    (void)post;
    rt_scene *rt = user;
    __atomic_add_fetch(&rt->bvh_live, (long long)bytes, __ATOMIC_RELAXED);
    long long live = __atomic_load_n(&rt->bvh_live, __ATOMIC_RELAXED);
    long long peak = __atomic_load_n(&rt->bvh_peak, __ATOMIC_RELAXED);
    while (live > peak && !__atomic_compare_exchange_n(&rt->bvh_peak, &peak, live, 1, __ATOMIC_RELAXED, __ATOMIC_RELAXED))
        ;
    return true;
}

/* The shading attributes every hit reads (rt_surface), per vertex and triangle of the scene's mesh. */
static int shading_attributes(rt_scene *rt, const scene *s, vx_err *e)
{
    const mesh *m = &s->mesh;
    rt->vertices = malloc(sizeof(rt_vertex) * (m->vertex_count ? m->vertex_count : 1));
    rt->face_normals = malloc(sizeof(vec3) * (m->triangle_count ? m->triangle_count : 1));
    if (!rt->vertices || !rt->face_normals)
        return vx_fail(e, "out of memory for %zu vertices' shading attributes", m->vertex_count);
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

static int build(rt_scene *rt, const scene *s, int flat, vx_err *e)
{
    memset(rt, 0, sizeof *rt);
    rt->scene = s;
    rt->device = rtcNewDevice(NULL);
    if (!rt->device)
        return vx_fail(e, "Embree: cannot create a device (error %d)", (int)rtcGetDeviceError(NULL));
    rtcSetDeviceErrorFunction(rt->device, embree_error, NULL);
    rtcSetDeviceMemoryMonitorFunction(rt->device, memory_monitor, rt);
    rt->bvh = rtcNewScene(rt->device);
    rtcSetSceneBuildQuality(rt->bvh, RTC_BUILD_QUALITY_HIGH);
    if (!flat && s->inst && s->inst->count) {
        if (rt_attach_instances(rt, s, e)) {
            rt_free(rt);
            return -1;
        }
    } else {
        RTCGeometry geom = rt_triangle_geometry(rt->device, &s->mesh);
        if (!geom) {
            rt_free(rt);
            return vx_fail(e, "Embree: cannot allocate geometry buffers for %zu triangles", s->mesh.triangle_count);
        }
        rtcAttachGeometry(rt->bvh, geom);
        rtcReleaseGeometry(geom);
    }
    rtcCommitScene(rt->bvh);
    if (rtcGetDeviceError(rt->device) != RTC_ERROR_NONE) {
        rt_free(rt);
        return vx_fail(e, "Embree: building the BVH failed");
    }
    rt->bvh_bytes = (size_t)(rt->bvh_peak > 0 ? rt->bvh_peak : 0);
    if (shading_attributes(rt, s, e)) {
        rt_free(rt);
        return -1;
    }
    return 0;
}

int rt_build(rt_scene *rt, const scene *s, vx_err *e) { return build(rt, s, 0, e); }

int rt_build_flat(rt_scene *rt, const scene *s, vx_err *e) { return build(rt, s, 1, e); }

void rt_free(rt_scene *rt)
{
    if (rt->bvh)
        rtcReleaseScene(rt->bvh);
    for (int i = 0; i < rt->proto_count; i++)
        if (rt->protos[i])
            rtcReleaseScene(rt->protos[i]);
    free(rt->protos);
    if (rt->device)
        rtcReleaseDevice(rt->device);
    free(rt->vertices);
    free(rt->face_normals);
    rt->bvh = NULL;
    rt->device = NULL;
    rt->vertices = NULL;
    rt->face_normals = NULL;
    rt->protos = NULL;
    rt->proto_count = 0;
}
