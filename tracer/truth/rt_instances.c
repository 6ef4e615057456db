/* Embree instances for an instanced scene (rt_instances.h). The prototypes' BVHs are built once;
 * each copy is an RTC_GEOMETRY_TYPE_INSTANCE with its object-to-world matrix, so the BVH memory
 * grows with the prototypes' triangles plus a few dozen bytes a copy. Embree intersects a copy in
 * the prototype's space and reports (instance, prototype triangle, u, v); the intersection filter
 * maps that to the mesh's triangle of the copy (and swaps u and v for a mirrored copy, whose
 * winding the expanded mesh reverses), so every caller keeps reading hit.primID as a triangle of
 * s->mesh. Embree commits the filtered hit (it is what the filter may modify), and for a
 * closest-hit query the filter runs on every candidate, which is the instanced truth's one extra
 * cost. Hit distances and barycentrics come from Embree's arithmetic in the prototype's space, so
 * they differ from the expanded mesh's in the last bits; the shading attributes do not. */
#include "rt_instances.h"

#include <stdlib.h>
#include <string.h>

#include "instancing.h"

/* A triangle geometry over the mesh (all of it): Embree's own buffers, as it may read past the last
 * vertex with 16-byte loads, which a shared buffer of ours would have to be padded for. */
RTCGeometry rt_triangle_geometry(RTCDevice device, const mesh *m)
{
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vb = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                        m->vertex_count);
    unsigned *ib = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                           m->triangle_count);
    if (!vb || !ib) {
        rtcReleaseGeometry(geom);
        return NULL;
    }
    memcpy(vb, m->positions, m->vertex_count * 3 * sizeof(float));
    memcpy(ib, m->indices, m->triangle_count * 3 * sizeof(unsigned));
    rtcCommitGeometry(geom);
    return geom;
}

/* Instance copies are attached with geomID = instance index; the other objects' triangles last. */
static void instance_filter(const struct RTCFilterFunctionNArguments *args)
{
    const scene_instancing *in = args->geometryUserPtr;
    unsigned *hit = (unsigned *)args->hit, N = args->N;
    float *hf = (float *)args->hit;
    unsigned id = args->context->instID[0];
    if (id >= in->count) /* cannot happen: every prototype is reached through an instance */
        return;
    const inst_instance *I = &in->inst[id];
    for (unsigned i = 0; i < N; i++) {
        if (args->valid[i] != -1)
            continue;
        uint32_t t = inst_triangle(I, hit[5 * N + i]);
        if (t == UINT32_MAX) { /* the copy's triangle has no area: the expanded mesh has no such triangle */
            args->valid[i] = 0;
            continue;
        }
        hit[5 * N + i] = t;
        if (I->mirror) {
            float u = hf[3 * N + i];
            hf[3 * N + i] = hf[4 * N + i];
            hf[4 * N + i] = u;
        }
    }
}

static void plain_filter(const struct RTCFilterFunctionNArguments *args)
{
    const scene_instancing *in = args->geometryUserPtr;
    unsigned *hit = (unsigned *)args->hit, N = args->N;
    for (unsigned i = 0; i < N; i++)
        if (args->valid[i] == -1)
            hit[5 * N + i] = in->plain[hit[5 * N + i]];
}

/* The triangles of the objects that are not instanced, with only the vertices they use. */
static int plain_mesh(const scene *s, mesh *out)
{
    const scene_instancing *in = s->inst;
    const mesh *m = &s->mesh;
    memset(out, 0, sizeof *out);
    uint32_t *map = malloc((m->vertex_count + 1) * sizeof *map);
    if (!map)
        return -1;
    memset(map, 0xff, (m->vertex_count + 1) * sizeof *map);
    for (size_t i = 0; i < in->plain_count; i++) {
        const uint32_t *x = m->indices + 3 * (size_t)in->plain[i];
        uint32_t v[3];
        for (int k = 0; k < 3; k++) {
            if (map[x[k]] == UINT32_MAX)
                map[x[k]] = mesh_add_vertex(out, mesh_position(m, x[k]), v3(0, 0, 1), 0, 0);
            v[k] = map[x[k]];
        }
        mesh_add_triangle(out, v[0], v[1], v[2], 0);
    }
    free(map);
    return 0;
}

int rt_attach_instances(rt_scene *rt, const scene *s, vx_err *e)
{
    const scene_instancing *in = s->inst;
    rt->instanced = 1;
    /* Embree 3.13.5 (Debian 12) never returns from a coherent rtcOccluded16 (the truth's shadow
     * packets) through instances once a coherent rtcIntersect16 has run, with the default top-level
     * BVH; the compact one (RTC_SCENE_FLAG_COMPACT) traverses correctly, and over a few thousand
     * instance boxes its cost is small. Checked by tests/test_instancing.py (a shadowed scene). */
    rtcSetSceneFlags(rt->bvh, RTC_SCENE_FLAG_COMPACT);
    rt->protos = calloc((size_t)in->proto_count, sizeof *rt->protos);
    if (!rt->protos)
        return vx_fail(e, "out of memory for %d prototypes", in->proto_count);
    rt->proto_count = in->proto_count;
    for (int p = 0; p < in->proto_count; p++) {
        RTCGeometry g = rt_triangle_geometry(rt->device, &in->protos[p]);
        if (!g)
            return vx_fail(e, "Embree: cannot allocate prototype %d's geometry buffers", p);
        rtcSetGeometryUserData(g, (void *)in);
        rtcSetGeometryIntersectFilterFunction(g, instance_filter);
        rtcCommitGeometry(g);
        rt->protos[p] = rtcNewScene(rt->device);
        rtcSetSceneBuildQuality(rt->protos[p], RTC_BUILD_QUALITY_HIGH);
        rtcAttachGeometry(rt->protos[p], g);
        rtcReleaseGeometry(g);
        rtcCommitScene(rt->protos[p]);
    }
    for (size_t i = 0; i < in->count; i++) {
        RTCGeometry g = rtcNewGeometry(rt->device, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(g, rt->protos[in->inst[i].proto]);
        rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, in->inst[i].m);
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(rt->bvh, g, (unsigned)i);
        rtcReleaseGeometry(g);
    }
    if (in->plain_count) {
        mesh pm;
        if (plain_mesh(s, &pm))
            return vx_fail(e, "out of memory for the scene's other objects");
        RTCGeometry g = rt_triangle_geometry(rt->device, &pm);
        mesh_free(&pm);
        if (!g)
            return vx_fail(e, "Embree: cannot allocate geometry buffers for %zu triangles", in->plain_count);
        rtcSetGeometryUserData(g, (void *)in);
        rtcSetGeometryIntersectFilterFunction(g, plain_filter);
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(rt->bvh, g, (unsigned)in->count);
        rtcReleaseGeometry(g);
    }
    return 0;
}
