/* The host side of precomputed shadows (shadow_maps_core.h): a render's or a truth's set of
 * light-space maps, built from the scene's triangles (slicemap, slicemap_build.c) or from a baked
 * model's opacity toward each light (slicemap-model, slicemap_model.c), cached per (scene, light,
 * resolution, model) in this process (shadow_cache.c), and what --stats reports of them. */
#ifndef VX_SHADOW_SET_H
#define VX_SHADOW_SET_H

#include <stddef.h>
#include <stdint.h>

#include "grid.h"
#include "model.h"
#include "scene.h"
#include "shadow_maps_core.h"

#define SHADOW_MAX_RES 2048      /* columns per side */
#define SHADOW_DEFAULT_RES 512   /* slicemap's default; slicemap-model's is 1.5 N for an N^3 grid (the
                                    light's view of the grid's cube is up to sqrt(3) N voxels wide) */

/* The maps of every light in one block (shadow_maps_core.h's layout), ready to query or upload. */
typedef struct {
    shadow_maps_params params;
    unsigned char *block; /* bits (uint64) | prefix (uint32) | T (float) | opaque (float) */
    size_t bytes;
    size_t words, values, columns; /* element counts of bits and prefix, T, opaque */
    size_t prefix_at, T_at, opaque_at; /* byte offsets of the arrays in block */
    double build_seconds;
    uint64_t key; /* shadow_cache.c's key */
} shadow_set;

struct map_build;
/* A builder of slicemap-model maps (slicemap_model.c's slicemap_fill_model), handed in by the
 * voxel renderers: the truth's code path does not link the marchers the model build runs. */
typedef int (*shadow_model_filler)(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                                   struct map_build *b, int threads, vx_err *e);

/* What a render or truth asks for: the method (SHADOW_*; -1: the scene's), the columns per side (0:
 * the method's default), the threads of the build, the model builder (NULL: the truth). */
typedef struct {
    int method;
    int res;
    int threads;
    shadow_model_filler fill_model;
} shadow_request;

/* What --stats reports: the method used (-1 when the scene declares no shadows: nothing was
 * computed), the precomputation's seconds (0 when served from the cache), bytes, columns per side,
 * whether it came from the cache, and the queries the render made. */
typedef struct {
    int method;
    int res;
    double build_seconds;
    size_t bytes;
    int cache_hit;
    uint64_t queries;
} shadow_stats;

/* "march", "slicemap", "slicemap-model", "voxel" -> SHADOW_*; -1 for another name. */
int shadow_method_from_name(const char *name);
const char *shadow_method_name(int method);
/* "march, slicemap, slicemap-model" (for messages and --help). */
#define SHADOW_METHOD_NAMES "march, slicemap, slicemap-model, voxel"

/* The method a render of s uses under request r: -1 when s does not declare shadows (nothing is
 * computed), else r's or the scene's. */
int shadow_effective_method(const scene *s, const shadow_request *r);

/* Fails as the build would (shadow_prepare) for a point light inside the scene's bounding sphere
 * under a method that builds maps, so that a caller can refuse it before any work: at every frame of
 * an animation, whose bounds move. */
int shadow_check_lights(const scene *s, const shadow_request *r, vx_err *e);
/* Whether shadow_check_lights can fail at some pose of s: a method that builds maps and a point
 * light (so that an animation's frames are posed and checked only then). */
int shadow_lights_depend_on_pose(const scene *s, const shadow_request *r);

/* A query view of set (NULL: none, the marchers march). */
void shadow_set_view(const shadow_set *set, shadow_maps *out);

/* The set for a render of s with model m (NULL for the truth) baked into g/records, or NULL when the
 * method is march or shadows are not declared (st says which). Built, or taken from this process's
 * cache; release it with shadow_release. Fails (with the option or field named) on a method the
 * caller cannot use: slicemap-model without a model, a point light inside the scene's bounds. */
int shadow_prepare(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                   const shadow_request *r, const shadow_set **out, shadow_stats *st, vx_err *e);
void shadow_release(const shadow_set *set);
/* Empties the cache (tests; a long-lived process that wants its memory back). */
void shadow_cache_clear(void);

/* The builders behind shadow_prepare (shadow_build.c): every light's map of s into out. */
int shadow_set_build(const scene *s, const voxel_grid *g, const vx_model *m, const void *records, int method,
                     int res, int threads, shadow_model_filler fill_model, shadow_set *out, vx_err *e);
/* The slicemap-model builder (slicemap_model.c), for the voxel renderers' shadow_request. */
int slicemap_fill_model(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                        struct map_build *b, int threads, vx_err *e);
void shadow_set_free(shadow_set *set);

#endif
