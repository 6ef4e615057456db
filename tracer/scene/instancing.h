/* Instancing (issue 19): an object drawn N times, each copy with its own placement, given as an
 * explicit list ("instances": [{"translate", "rotate_deg", "scale"}, ...]) or a seeded scatter over
 * a surface ("scatter": {"count", "seed", "over", "scale_range", "rotate_y"}); format in README.md.
 *
 * What is kept: the prototype (the object as loaded, after its own "transform") once, and per
 * instance its placement. Copies are never written out: the scene's mesh holds only the objects
 * that are not instanced, and every consumer walks the copies on the fly (scene_tris.h numbers
 * them after the mesh's triangles): the truth builds one Embree BVH per prototype under an
 * instance geometry per copy (tracer/truth/rt_instances.c), the voxeliser places each copy's
 * triangles as it goes (tracer/grid), and the bake sampler's per-voxel triangle lists come from
 * point queries through the instances (tracer/bake). A copy's vertices are placed with exactly the
 * arithmetic of an object's "transform" (xform_point), so the instanced and the written-out forms
 * of a scene give the same grid and the same bake. Memory grows with the prototypes' triangles plus
 * about 200 bytes a copy, which is what lets a forest of 10^8 triangles load in a few hundred MB. */
#ifndef VX_INSTANCING_H
#define VX_INSTANCING_H

#include <stddef.h>
#include <stdint.h>

#include <cjson/cJSON.h>
#include "error.h"
#include "mesh.h"
#include "scene.h"
#include "xform.h"

/* Triangles over all instances: their numbers (scene_tris.h) must fit 32 bits beside the mesh's. */
#define INST_MAX_TRIANGLES ((size_t)1 << 31)
#define INST_MAX_COUNT 1000000 /* instances of one object */

typedef struct {
    int proto;
    float m[12];     /* object -> world, row-major 3x4 (Embree's RTC_FORMAT_FLOAT3X4_ROW_MAJOR) */
    xform_exact x;   /* the same placement, for vertices placed exactly as a "transform" would */
    int mirror;      /* the placement mirrors: the copy's winding is reversed (corners 1 and 2 swap) */
    size_t offset;   /* number of the copy's first triangle among all copies' (scene_tris.h) */
    float lo[3], hi[3]; /* bounds of the copy's placed corners (inst_compute_bounds, at load) */
} inst_instance;

typedef struct {
    char *name;
    size_t t0, t1; /* its triangles in the scene's mesh */
    int animated, instanced;
} inst_named;

typedef struct scene_instancing {
    mesh *protos; /* as loaded (after the object's "transform"), zero-area triangles included */
    int proto_count;
    inst_instance *inst;
    size_t count;
    size_t triangles;  /* over all copies */
    double lo[3], hi[3]; /* bounds of every copy's corners (scene_tris.h) */
    inst_named *named; /* objects with a "name", for "scatter": {"over"} */
    int named_count;
} scene_instancing;

/* scene.c's hook. After an object is loaded and transformed (its vertices from v0, triangles from
 * t0): records its "name", and replaces it by its instances when it has "instances" or "scatter"
 * (the object's triangles leave the mesh and become a prototype). */
int inst_parse_object(scene *s, const cJSON *object, const char *where, size_t v0, size_t t0, vx_err *e);
void inst_free(scene_instancing *in);

#endif
