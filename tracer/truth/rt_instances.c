/* Embree instances for an instanced scene (rt_instances.h). The prototypes' BVHs are built once;
 * each copy is an RTC_GEOMETRY_TYPE_INSTANCE with its object-to-world matrix, so the BVH memory
 * grows with the prototypes' triangles plus a few dozen bytes a copy. Embree intersects a copy in
 * the prototype's space and reports (instance, prototype triangle, u, v); rt_surface_instance
 * shades that from the prototype's attributes placed as the written-out copy has them. Hit
 * distances and barycentrics come from Embree's arithmetic in the prototype's space, so they may
 * differ from the expanded form's in the last bits; the attributes at a given (u, v) do not. */
#include "rt_instances.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "instancing.h"
#include "rt_attributes.h"
#include "scene_tris.h"

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

void rt_surface_instance(const rt_scene *rt, unsigned inst, unsigned prim, float u, float v, vec3 origin, vec3 dir,
                         float t, surface_hit *out)
{
    const scene *s = rt->scene;
    const inst_instance *I = &s->inst->inst[inst];
    const mesh *m = &s->inst->protos[I->proto];
    const uint32_t *tri = &m->indices[3 * (size_t)prim];
    const rt_vertex *pv = rt->proto_vertices[I->proto];
    /* The copy as written out: corners in its winding (1 and 2 swapped when the placement
     * mirrors, and Embree's (u, v) with them), placed with the arithmetic of a "transform", the
     * face normal from the placed corners as rt_mesh_attributes takes it. So a hit shades as on
     * the expanded scene's triangle, bit for bit for the same (u, v). */
    static const int order[2][3] = {{0, 1, 2}, {0, 2, 1}};
    const int *o = order[I->mirror ? 1 : 0];
    if (I->mirror) {
        float tmp = u;
        u = v, v = tmp;
    }
    rt_vertex c[3];
    float p[9];
    inst_corners(s->inst, I, prim, p);
    for (int k = 0; k < 3; k++) {
        c[k] = pv[tri[o[k]]];
        xform_normal(&I->x, c[k].normal, c[k].normal);
    }
    vec3 a = v3(p[0], p[1], p[2]), b = v3(p[3], p[4], p[5]), d = v3(p[6], p[7], p[8]);
    vec3 ng = v3_normalize(v3_cross(v3_sub(b, a), v3_sub(d, a)));
    float w = 1.0f - u - v;
    rt_shade(s, &s->materials[m->materials[prim]], ng, rt_interpolate_normal(&c[0], &c[1], &c[2], w, u, v), &c[0], &c[1],
             &c[2], w, u, v, origin, dir, t, out);
}

int rt_attach_instances(rt_scene *rt, const scene *s, vx_err *e)
{
    const scene_instancing *in = s->inst;
    /* Embree 3.13.5 (Debian 12) never returns from a coherent rtcOccluded16 (the truth's shadow
     * packets) through instances once a coherent rtcIntersect16 has run, with the default top-level
     * BVH; the compact one (RTC_SCENE_FLAG_COMPACT) traverses correctly, and over a few thousand
     * instance boxes its cost is small. Checked by tests/test_instancing.py (a shadowed scene). */
    rtcSetSceneFlags(rt->bvh, RTC_SCENE_FLAG_COMPACT);
    rt->protos = calloc((size_t)in->proto_count, sizeof *rt->protos);
    rt->proto_vertices = calloc((size_t)in->proto_count, sizeof *rt->proto_vertices);
    if (!rt->protos || !rt->proto_vertices)
        return vx_fail(e, "out of memory for %d prototypes", in->proto_count);
    rt->proto_count = in->proto_count;
    for (int p = 0; p < in->proto_count; p++) {
        if (rt_mesh_attributes(&in->protos[p], &rt->proto_vertices[p], NULL))
            return vx_fail(e, "out of memory for prototype %d's shading attributes", p);
        RTCGeometry g = rt_triangle_geometry(rt->device, &in->protos[p]);
        if (!g)
            return vx_fail(e, "Embree: cannot allocate prototype %d's geometry buffers", p);
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
    if (s->mesh.triangle_count) { /* the objects drawn once: the mesh itself, primID its triangle */
        RTCGeometry g = rt_triangle_geometry(rt->device, &s->mesh);
        if (!g)
            return vx_fail(e, "Embree: cannot allocate geometry buffers for %zu triangles", s->mesh.triangle_count);
        rtcAttachGeometryByID(rt->bvh, g, (unsigned)in->count);
        rtcReleaseGeometry(g);
    }
    return 0;
}

/* ---- Point queries (rt_query_sphere): Embree 3.13 takes a point query's centre into a copy's
 * space but leaves its radius as it was, so a copy scaled by 0.6 lost triangles that its
 * written-out form's query found (checked by tests/test_instancing.py's shrunk copy). The copies
 * are therefore visited by hand: the query scene holds the mesh's triangles and one user
 * primitive per copy (its world bounds), and a copy the sphere reaches is queried in its
 * prototype's BVH with the sphere taken into the prototype's space, radius divided by the copy's
 * smallest scale: the image of the world sphere lies inside that one, whatever the placement. */

typedef struct {
    const rt_scene *rt;
    rt_triangle_visit visit;
    void *user;
    unsigned inst; /* the copy being visited inside its prototype */
} query_walk;

/* A copy's box: the exact bounds of its placed corners, computed once at load (inst_compute_bounds),
 * so every triangle a query may need lies inside it. */
static void box_bounds(const struct RTCBoundsFunctionArguments *args)
{
    const inst_instance *I = (const inst_instance *)args->geometryUserPtr + args->primID;
    struct RTCBounds *o = args->bounds_o;
    o->lower_x = I->lo[0], o->lower_y = I->lo[1], o->lower_z = I->lo[2];
    o->upper_x = I->hi[0], o->upper_y = I->hi[1], o->upper_z = I->hi[2];
}

static bool visit_proto_triangle(struct RTCPointQueryFunctionArguments *args)
{
    query_walk *w = args->userPtr;
    w->visit(w->user, w->inst, args->primID);
    return false;
}

static bool visit_top(struct RTCPointQueryFunctionArguments *args)
{
    query_walk *w = args->userPtr;
    if (args->geomID == 0) { /* the mesh's own triangles */
        w->visit(w->user, RTC_INVALID_GEOMETRY_ID, args->primID);
        return false;
    }
    const inst_instance *I = &w->rt->scene->inst->inst[args->primID];
    /* The centre into the prototype's space: undo the translation, the turns about z, y, x (in
     * that order, each by its negative angle), then the scale. */
    double P[3] = {args->query->x - (double)I->x.translate.x, args->query->y - (double)I->x.translate.y,
                   args->query->z - (double)I->x.translate.z};
    for (int axis = 2; axis >= 0; axis--) {
        int a = (axis + 1) % 3, b = (axis + 2) % 3;
        double c = I->x.cs[axis][0], sn = I->x.cs[axis][1];
        double pa = c * P[a] + sn * P[b], pb = -sn * P[a] + c * P[b];
        P[a] = pa, P[b] = pb;
    }
    vec3 k = I->x.scale;
    double smin = vx_fmin(fabs((double)k.x), vx_fmin(fabs((double)k.y), fabs((double)k.z)));
    struct RTCPointQuery q = {(float)(P[0] / k.x), (float)(P[1] / k.y), (float)(P[2] / k.z), 0.0f,
                              (float)(args->query->radius / smin * 1.0001) + 1e-30f};
    struct RTCPointQueryContext ctx;
    rtcInitPointQueryContext(&ctx);
    query_walk inner = *w;
    inner.inst = args->primID;
    rtcPointQuery(w->rt->protos[I->proto], &q, &ctx, visit_proto_triangle, &inner);
    return false;
}

static bool visit_plain(struct RTCPointQueryFunctionArguments *args)
{
    query_walk *w = args->userPtr;
    w->visit(w->user, RTC_INVALID_GEOMETRY_ID, args->primID);
    return false;
}

void rt_query_sphere(const rt_scene *rt, const float centre[3], float radius, rt_triangle_visit visit, void *user)
{
    query_walk w = {rt, visit, user, RTC_INVALID_GEOMETRY_ID};
    struct RTCPointQuery q = {centre[0], centre[1], centre[2], 0.0f, radius};
    struct RTCPointQueryContext ctx;
    rtcInitPointQueryContext(&ctx);
    if (rt->query)
        rtcPointQuery(rt->query, &q, &ctx, visit_top, &w);
    else
        rtcPointQuery(rt->bvh, &q, &ctx, visit_plain, &w);
}

int rt_build_queries(rt_scene *rt, vx_err *e)
{
    const scene *s = rt->scene;
    const scene_instancing *in = s->inst;
    if (!in || in->count == 0 || rt->query)
        return 0;
    rt->query = rtcNewScene(rt->device);
    RTCGeometry plain = s->mesh.triangle_count ? rt_triangle_geometry(rt->device, &s->mesh) : NULL;
    if (s->mesh.triangle_count && !plain)
        return vx_fail(e, "Embree: cannot allocate geometry buffers for %zu triangles", s->mesh.triangle_count);
    if (plain) {
        rtcAttachGeometryByID(rt->query, plain, 0);
        rtcReleaseGeometry(plain);
    }
    RTCGeometry boxes = rtcNewGeometry(rt->device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(boxes, (unsigned)in->count);
    rtcSetGeometryUserData(boxes, in->inst);
    rtcSetGeometryBoundsFunction(boxes, box_bounds, in->inst);
    rtcCommitGeometry(boxes);
    rtcAttachGeometryByID(rt->query, boxes, 1);
    rtcReleaseGeometry(boxes);
    rtcCommitScene(rt->query);
    if (rtcGetDeviceError(rt->device) != RTC_ERROR_NONE)
        return vx_fail(e, "Embree: building the instance query scene failed");
    return 0;
}
