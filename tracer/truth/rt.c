#include "rt.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "instancing.h"
#include "parallel.h"
#include "rt_attributes.h"
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
    if (rt_mesh_attributes(&s->mesh, &rt->vertices, &rt->face_normals))
        return vx_fail(e, "out of memory for %zu vertices' shading attributes", s->mesh.vertex_count);
    rt->epsilon = scene_surface_epsilon(s);
    return 0;
}

int rt_build(rt_scene *rt, const scene *s, vx_err *e)
{
    memset(rt, 0, sizeof *rt);
    rt->scene = s;
    double t0 = now_seconds();
    rt->device = rtcNewDevice(NULL);
    if (!rt->device)
        return vx_fail(e, "Embree: cannot create a device (error %d)", (int)rtcGetDeviceError(NULL));
    rtcSetDeviceErrorFunction(rt->device, embree_error, NULL);
    rtcSetDeviceMemoryMonitorFunction(rt->device, memory_monitor, rt);
    rt->bvh = rtcNewScene(rt->device);
    rtcSetSceneBuildQuality(rt->bvh, RTC_BUILD_QUALITY_HIGH);
    if (s->inst && s->inst->count) {
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
    if (rt_build_queries(rt, e)) { /* after bvh_bytes: that figure is the truth's BVH */
        rt_free(rt);
        return -1;
    }
    if (shading_attributes(rt, s, e)) {
        rt_free(rt);
        return -1;
    }
    rt->bvh_seconds = now_seconds() - t0;
    return 0;
}

void rt_free(rt_scene *rt)
{
    if (rt->bvh)
        rtcReleaseScene(rt->bvh);
    if (rt->query)
        rtcReleaseScene(rt->query);
    rt->query = NULL;
    for (int i = 0; i < rt->proto_count; i++) {
        if (rt->protos[i])
            rtcReleaseScene(rt->protos[i]);
        free(rt->proto_vertices[i]);
    }
    free(rt->protos);
    free(rt->proto_vertices);
    rt->proto_vertices = NULL;
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
