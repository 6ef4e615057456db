/* The appearance-model interface. A model is one file in models/ plus one line in
 * models/registry.c; the tracer only ever talks to this interface and never names a model.
 *
 * What a model declares:
 *  - its name, a one-line description and the bytes of its per-voxel record;
 *  - how it bakes a voxel's record from the shared bake sampler's rays (bake_voxel), and optionally
 *    a pass over the whole grid afterwards (bake_finish: MIP levels, neighbourhood filters);
 *  - how it answers a query (voxel, view direction, pixel footprint, lights): its directional
 *    opacity (also used for shadow rays) and its radiance, plus an A-buffer coverage mask for models
 *    that composite with masks;
 *  - which compositing rule the tracer applies: first hit, front-to-back alpha, or coverage masks.
 *
 * Per-voxel evaluation (opacity, shade) is portable C: no libc beyond <math.h>, no allocation, no
 * I/O, fixed-size structs, buffers behind the VX_GLOBAL address-space macro, so that the same source
 * compiles as OpenCL C for the OpenCL backend. */
#ifndef VX_MODEL_H
#define VX_MODEL_H

#include "vec.h"

#ifdef __OPENCL_VERSION__
#define VX_GLOBAL __global
#else
#include <stddef.h>
#include <stdint.h>
#define VX_GLOBAL
#endif

#define VX_MAX_LIGHTS 8
#define VX_MASK_WORDS 4 /* 128-sample coverage masks (Heitz & Neyret: four 32-bit words) */

enum {
    VX_COMPOSITE_FIRST_HIT = 0, /* the first voxel with opacity > 0 gives the pixel's colour */
    VX_COMPOSITE_ALPHA = 1,     /* front to back: C += (1 - A) a c, A += (1 - A) a */
    VX_COMPOSITE_COVERAGE = 2,  /* A-buffer: L += L_d popcount(M_d & ~A) / 128, A |= M_d */
};

enum {
    VX_MARCH_VOXELS = 0, /* the tracer visits the level-0 voxels along each ray (3D-DDA) */
    VX_MARCH_CONE = 1,   /* the tracer steps cone elements (length = diameter) along each ray, the
                            MIP level following the cone's width, and asks cone_element at each */
};

/* Effect bits a model may test (same values as scene.h's EFFECT_*). */
enum { VX_EFFECT_SHADOWS = 1, VX_EFFECT_SPECULAR = 2, VX_EFFECT_DOF = 4, VX_EFFECT_TEXTURES = 8 };

/* A query: one voxel seen along one ray (or cone), with the lights that reach it. */
typedef struct {
    vec3 to_viewer;      /* unit vector from the voxel toward the eye (minus the ray direction) */
    vec3 ray_origin;     /* the ray, and the segment [t0, t1] of it inside the voxel */
    vec3 ray_dir;        /* unit */
    float t0, t1;
    vec3 voxel_lo;       /* the voxel's lower corner and edge length (world units) */
    float voxel_size;
    float footprint;     /* radius of the pixel's cone at the voxel (world units) */
    unsigned effects;    /* VX_EFFECT_* declared by the scene */
    int light_count;
    vec3 to_light[VX_MAX_LIGHTS];   /* unit, from the voxel centre toward each light */
    vec3 irradiance[VX_MAX_LIGHTS]; /* irradiance on a facing surface, shadows already applied */
    /* Cone marching only: each light's distance from `position` (INFINITY for a directional light;
     * 0 when the tracer did not say), so that a model whose surface lies away from the element's
     * centre can light the surface where it is, as the ground truth does. */
    float light_distance[VX_MAX_LIGHTS];
    /* Cone marching (VX_MARCH_CONE) only: the element's centre, its MIP level (fractional: the
     * model interpolates between floor and ceil), and the grid and records to look up. */
    vec3 position;
    float level;
    const struct voxel_grid *grid;
    VX_GLOBAL const void *records;
    VX_GLOBAL const void *table; /* the model's constant table (vx_model.table), on either backend */
} vx_query;

/* A model's answer to a query. */
typedef struct {
    vec3 radiance;                  /* outgoing radiance toward the viewer (not premultiplied) */
    float opacity;                  /* in [0, 1] */
    unsigned int mask[VX_MASK_WORDS]; /* coverage of the footprint (VX_COMPOSITE_COVERAGE only) */
} vx_answer;

/* One ray of the shared bake sampler (see tracer/bake/bake.h): Brito et al. 2023 §3.2's classification,
 * the one every model derives its occlusion from. The ray is intersected with the voxel's own
 * triangles only (those overlapping the voxel's closed box), over its whole length from outside the
 * scene; its closest own-triangle crossing decides:
 *   (a) inside the voxel: INSIDE_FRONT (front side, or either side of a double-sided material:
 *       normal and colour recorded, occlusion 1) or INSIDE_BACK (the back of a single-sided
 *       surface: occlusion 1 only);
 *   (b) outside the voxel, before its entry or after its exit: OUTSIDE (occlusion 1 only);
 *   (c) no crossing at all: MISS (occlusion 0, but the ray still counts as traversing the voxel).
 * Other geometry never shadows a voxel's statistics: the paper intersects the voxel's list alone. */
enum {
    VX_SAMPLE_MISS = 0,         /* case (c) */
    VX_SAMPLE_INSIDE_FRONT = 1, /* case (a), front side (or a double-sided material) */
    VX_SAMPLE_INSIDE_BACK = 2,  /* case (a), back side of a single-sided material */
    VX_SAMPLE_OUTSIDE = 3,      /* case (b) */
};

typedef struct {
    vec3 origin;      /* outside the scene's bounds */
    vec3 dir;         /* unit, uniform on the sphere */
    float t_entry;    /* the ray's interval inside the voxel */
    float t_exit;
    float t_hit;      /* closest own-triangle crossing (a, b); INFINITY for a miss */
    int kind;         /* VX_SAMPLE_* */
    vec3 normal;      /* shading normal at the hit, turned toward the ray's side (INSIDE hits only) */
    vec3 albedo;      /* diffuse colour at the hit (front hits of shaded surfaces; else 0) */
    float specular;   /* the hit material's specular reflectance and roughness (INSIDE hits only) */
    float roughness;
    int double_sided; /* INSIDE hits: the material is double-sided */
    int back_side;    /* INSIDE hits: the ray met the triangle's back; `normal` was turned toward the ray,
                         so -normal is the surface's own (front-side) orientation */
} vx_sample;

#ifndef __OPENCL_VERSION__ /* the bake runs on the host only */
/* Whether the sample occludes the voxel (cases a and b). */
static inline int vx_sample_occludes(const vx_sample *s)
{
    return s->kind == VX_SAMPLE_INSIDE_FRONT || s->kind == VX_SAMPLE_INSIDE_BACK || s->kind == VX_SAMPLE_OUTSIDE;
}

/* The hit's normal on the surface's own front side (INSIDE hits): what averages of a double-sided
 * surface must add up, or the two sides' normals cancel. */
static inline vec3 vx_sample_front_normal(const vx_sample *s)
{
    return s->back_side ? v3_scale(s->normal, -1.0f) : s->normal;
}
#endif

/* What a model knows about the voxel it bakes. */
typedef struct {
    int x, y, z;        /* level-0 cell */
    long long index;    /* dense index */
    vec3 lo;            /* lower corner */
    float size;         /* edge length */
    unsigned effects;
} vx_voxel;

struct voxel_grid;

#ifndef __OPENCL_VERSION__
/* Where a record read back from a .vox file sits, for validate_record. */
typedef struct {
    int level;       /* its MIP level (0 for models without levels) */
    float cell_size; /* edge length of that level's cells (world units) */
    int rays;        /* sample rays per voxel of the bake (a bound on any per-voxel sample count) */
} vx_record_context;

typedef struct vx_model {
    const char *name;
    const char *description;
    size_t voxel_bytes;  /* size of one per-voxel record */
    int compositing;     /* VX_COMPOSITE_* */
    /* 0: one record per non-empty level-0 voxel. 1: records for every MIP level too, level 0 first,
     * then level 1, ... (each level's records in its dense-index order); bake_voxel fills level 0
     * and bake_finish the coarser levels. */
    int uses_levels;
    int march; /* VX_MARCH_* */
    /* Fills the record `out` (voxel_bytes, zeroed) from the voxel's n sample rays. Called from
     * several threads at once, for different voxels. */
    void (*bake_voxel)(const vx_voxel *v, const vx_sample *samples, int n, void *out);
    /* Optional (may be NULL): runs once after every voxel is baked, with the whole grid and all
     * records (see uses_levels). Returns 0, or -1 on failure. */
    int (*bake_finish)(const struct voxel_grid *g, void *records);
    /* Directional opacity of the voxel along q->ray_dir (for a shadow ray, the direction toward the
     * light). */
    float (*opacity)(VX_GLOBAL const void *record, const vx_query *q);
    /* Radiance toward q->to_viewer (and the coverage mask for VX_COMPOSITE_COVERAGE); a->opacity
     * holds the opacity the tracer already computed. */
    void (*shade)(VX_GLOBAL const void *record, const vx_query *q, vx_answer *a);
    /* VX_MARCH_CONE models only (NULL otherwise): the answer of the cone element described by q
     * (position, level, footprint, to_viewer, lights), looked up in q->grid / q->records. */
    void (*cone_element)(const vx_query *q, vx_answer *a);
    /* The OpenCL backend (tracer/backends/opencl/opencl_backend.c) compiles the model's per-voxel evaluation from
     * the same source as the C build: cl_source names a header under models/ (e.g.
     * "binary_eval.h") that compiles as OpenCL C, and cl_opacity / cl_shade name its functions there
     * with the signatures of opacity and shade above (the C model points opacity and shade at those
     * same functions, or at thin wrappers of them). NULL cl_source: the model cannot run on OpenCL,
     * and `render --backend opencl` says so. The tracer reads these fields and never names a model. */
    const char *cl_source;
    const char *cl_opacity;
    const char *cl_shade;
    /* VX_MARCH_CONE models: cl_cone_element names the function in cl_source with cone_element's
     * signature (the C model's cone_element calls the same function), which the OpenCL cone kernel
     * (tracer/backends/opencl/cl/render_cone.cl) calls; then cl_opacity and cl_shade may be NULL. */
    const char *cl_cone_element;
    /* Optional (may be NULL): a constant table the model's evaluation reads through q->table (e.g.
     * precomputed masks), built once on the host; the tracer hands it to cone_element on the C
     * backend and uploads it as a buffer on OpenCL. Returns the table and its size in bytes. */
    const void *(*table)(size_t *bytes);
    /* Optional (may be NULL): states what a record may hold, for records read from a .vox file
     * (a checksum only guards against accidents; a crafted or buggy file must not reach the
     * evaluation with NaN, infinities or out-of-range codes). Returns 0 when the record is one the
     * bake could have written, else writes "FIELD: what is wrong" into why and returns -1. */
    int (*validate_record)(const void *record, const vx_record_context *c, char *why, size_t why_size);
} vx_model;

/* The registry (models/registry.c). */
const vx_model *model_find(const char *name);
const vx_model *const *model_all(void); /* NULL-terminated */
#endif

#endif
