/* Instancing (issue 19): an object drawn N times, each copy with its own placement, given as an
 * explicit list ("instances": [{"translate", "rotate_deg", "scale"}, ...]) or a seeded scatter over
 * a surface ("scatter": {"count", "seed", "over", "scale_range", "rotate_y"}); format in README.md.
 *
 * What is kept: the prototype (the object as loaded, after its own "transform") once, and per
 * instance its object-to-world matrix. The truth builds one Embree BVH per prototype and an
 * instance geometry per copy (tracer/truth/rt.c), so its BVH grows with the prototypes, not the
 * copies. The scene's mesh also holds every copy written out (expanded), exactly as the same
 * object repeated with each instance's placement as its "transform" would load: the voxeliser
 * (tracer/grid), the bake sampler (tracer/bake), the moving-object parts and the --dry-run
 * estimate read that mesh, so their results are those of the expanded scene by construction.
 * Walking the instances in the grid and the bake without the expanded mesh is issue 19's next step;
 * the expanded copy is also what the truth's hits read their shading attributes from (a hit on
 * instance i's prototype triangle p is the mesh's triangle of that copy), so a hit reports the
 * material, normals and colour the expanded mesh has, bit for bit. */
#ifndef VX_INSTANCING_H
#define VX_INSTANCING_H

#include <stddef.h>
#include <stdint.h>

#include <cjson/cJSON.h>
#include "error.h"
#include "mesh.h"
#include "scene.h"

/* Copies expanded for the voxeliser and the bake: at most this many triangles over all instances
 * (the mesh's 32-bit indices, and memory: about 100 bytes a copied triangle). */
#define INST_MAX_TRIANGLES (1u << 26)
#define INST_MAX_COUNT 1000000 /* instances of one object */

typedef struct {
    int proto;
    float m[12];     /* object -> world, row-major 3x4 (Embree's RTC_FORMAT_FLOAT3X4_ROW_MAJOR) */
    int mirror;      /* the placement mirrors: the copy's winding is reversed, so (u, v) swap */
    size_t t_old;    /* first triangle of the copy in the mesh before zero-area triangles were dropped */
    uint32_t base;   /* first triangle of the copy after the drop (when remap is NULL) */
    uint32_t *remap; /* per prototype triangle: the copy's triangle, UINT32_MAX when dropped; NULL
                      * when the copy kept every triangle (then base + p) */
} inst_instance;

typedef struct {
    char *name;
    size_t t0, t1; /* its triangles before the drop */
    int animated;
} inst_named;

typedef struct scene_instancing {
    mesh *protos; /* as loaded (after the object's "transform"), zero-area triangles included */
    int proto_count;
    inst_instance *inst;
    size_t count;
    uint32_t *plain; /* the mesh's triangles that belong to no instance (after the drop) */
    size_t plain_count;
    size_t expanded_triangles; /* triangles copied for the instances */
    inst_named *named;         /* objects with a "name", for "scatter": {"over"} */
    int named_count;
} scene_instancing;

/* scene.c's hooks. After an object is loaded and transformed (its vertices from v0, triangles from
 * t0): records its "name", and replaces it by its instances when it has "instances" or "scatter". */
int inst_parse_object(scene *s, const cJSON *object, const char *where, size_t v0, size_t t0, vx_err *e);
/* After zero-area triangles were dropped (map[t]: triangle t's new index or UINT32_MAX): where
 * each copy's triangles now are, and the triangles outside every copy. */
int inst_finalize(scene *s, const uint32_t *map, size_t old_count, vx_err *e);
void inst_free(scene_instancing *in);

/* The mesh triangle a hit on instance i's prototype triangle p stands for; UINT32_MAX when that
 * copy's triangle was dropped (zero area after the placement). */
static inline uint32_t inst_triangle(const inst_instance *in, uint32_t p)
{
    return in->remap ? in->remap[p] : in->base + p;
}

#endif
