/* A loaded scene: triangles with materials, camera, lights, background, default image size and the
 * declared effects. Loaded from a JSON scene file (format in README.md). */
#ifndef VX_SCENE_H
#define VX_SCENE_H

#include <stdint.h>

#include "camera.h"
#include "error.h"
#include "light.h"
#include "mesh.h"
#include "texture.h"
#include "vec.h"

#define SCENE_MAX_SHADOW_RES 2048 /* "shadows": {"resolution"} (shadow_set.h's SHADOW_MAX_RES) */

/* Effects a scene may declare; nothing undeclared is computed anywhere. */
enum {
    EFFECT_SHADOWS = 1u << 0,
    EFFECT_SPECULAR = 1u << 1,
    EFFECT_DOF = 1u << 2,
    EFFECT_TEXTURES = 1u << 3,
};

typedef struct {
    vec3 color;       /* diffuse albedo (multiplied by the texture and vertex colour) */
    float specular;   /* specular reflectance at normal incidence (used only with EFFECT_SPECULAR) */
    float roughness;  /* Beckmann RMS slope alpha of the specular lobe */
    int double_sided; /* back faces are shaded like front faces; otherwise they are black occluders */
    int texture;      /* index into scene.textures, or -1 */
} material;

typedef struct {
    char *path; /* the scene file, for messages */
    char *name;
    mesh mesh;
    material *materials;
    float *shadow_sigma; /* per material: σ of slicemap shadows (Eisemann & Decoret §3.1), 0 = opaque */
    char **material_names;
    int material_count;
    texture *textures;
    int texture_count;
    light *lights;
    int light_count;
    camera camera;
    vec3 background;
    int width, height;
    unsigned effects;
    int shadow_method; /* "shadows": {"method"}: shadow_maps_core.h's SHADOW_* (0, march, by default) */
    int shadow_res;    /* "shadows": {"resolution"}: columns per side of the shadow maps (0: the default) */
    size_t degenerate_triangles; /* zero-area triangles dropped at load time */
    vec3 bounds_lo, bounds_hi;
    uint64_t identity; /* hash of geometry, materials and textures: baked files name the scene they belong to */
    uint64_t texture_identity; /* the textures' part of it (kinds, sizes, texels, checkers), hashed once */
    int texture_identity_done;
    struct scene_animation *anim; /* "frames" and moving objects (animation.h), NULL when none */
    struct scene_instancing *inst; /* instanced objects' prototypes and placements (instancing.h), or NULL */
    /* The files the load read besides the scene file (meshes, texture images), as opened, with the
     * field naming each ("objects[0].ply", "materials.wood.texture"): a command refuses an output
     * that would overwrite one of them (tracer/cli/outputs.h). A glTF's own buffers and images are
     * not listed. */
    char **inputs, **input_fields;
    int input_count;
} scene;

#ifdef __cplusplus
extern "C" {
#endif

int scene_load(const char *path, scene *s, vx_err *e);
/* The same from the JSON text itself (the Python API's scenes given as dicts: no temporary file).
 * path stands for the file: messages name it and relative paths inside (meshes, textures) resolve
 * against its directory, as for a file at that path. */
int scene_load_text(const char *text, const char *path, scene *s, vx_err *e);
void scene_free(scene *s);
/* Poses an animated scene's moving objects at `frame` (animation.h) and updates its bounds and
 * identity. The frame must lie in the scene's "frames" [A, B] ([0, 0] for a scene without them). */
int scene_set_frame(scene *s, int frame, vx_err *e);
/* How far the truth's shadow rays start off a surface (rt.c, truth.c), in one place so that loading
 * a scene can tell when float positions are too coarse for it: at least the scene's epsilon, large
 * enough to leave the surface at float precision far from the origin, small against the scene (from
 * its bounds: its size and their largest coordinate)... */
float scene_surface_epsilon(const scene *s);
/* ...or, where larger, this fraction of |ray origin| + t |ray direction|, the hit point's own
 * rounding (truth.c's shadow_offset). */
#define SCENE_HIT_ROUNDING 1e-6f
/* Parses "shadows", "specular", "dof", "textures"; returns 0 for an unknown name. */
unsigned effect_from_name(const char *name);
const char *effect_name(unsigned effect);
/* Parses a --size WxH option with the same limits as a scene's "size". */
int scene_parse_size_string(const char *text, int *w, int *h, vx_err *e);

#ifdef __cplusplus
}
#endif

#endif
