/* Procedural scene generators. A scene file's object {"generator": NAME, "seed": S, "params": {...},
 * "materials": {SLOT: MATERIAL}} calls one of these. Generators are deterministic for a seed and
 * write triangles into a mesh, each tagged with the scene material bound to one of its slots. */
#ifndef VX_GENERATOR_H
#define VX_GENERATOR_H

#include <cjson/cJSON.h>
#include <stdint.h>

#include "error.h"
#include "mesh.h"

typedef struct {
    const char *name;
    const char *description;
    /* Material slot names, NULL-terminated. */
    const char *const *slots;
    /* params may be NULL (all defaults); `where` names params in messages (see json_util.h).
     * slot_materials[i] is the scene material index for slots[i]. */
    int (*generate)(const cJSON *params, const char *where, uint64_t seed, const uint32_t *slot_materials,
                    mesh *out, vx_err *e);
} scene_generator;

/* NULL when no generator has that name. */
const scene_generator *generator_find(const char *name);
/* NULL-terminated list of every generator. */
const scene_generator *const *generator_all(void);

#endif
