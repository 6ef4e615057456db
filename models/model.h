/* The appearance-model interface. A model is one folder models/<name>/ plus one line in
 * models/registry.c; the tracer only ever talks to this interface and never names a model.
 *
 * What a model declares (vx_model, at the end):
 *  - identity: its name and a one-line description;
 *  - its per-voxel record: bytes, a layout version (checked when a .vox is loaded) and whether it
 *    has MIP levels;
 *  - its bake: a voxel's record from the shared bake sampler's rays (bake_voxel), optionally a pass
 *    over the whole grid afterwards (bake_finish: MIP levels, neighbourhood filters), its
 *    parameters and what a valid record may hold (validate_record);
 *  - exactly one evaluation protocol: per voxel (vx_voxel_eval: directional opacity, also used for
 *    shadow rays, and radiance; first-hit or alpha compositing) or per cone element (vx_cone_eval:
 *    coverage mask and radiance; A-buffer compositing).
 *
 * Evaluation is portable C: no libc beyond <math.h>, no allocation, no I/O, fixed-size structs,
 * buffers behind the VX_GLOBAL address-space macro, so that the same source compiles as OpenCL C
 * for the OpenCL backend. ARCHITECTURE.md says how to add a model. */
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
    /* Cone evaluation (vx_cone_eval) only: the element's centre, its MIP level (fractional: the
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
    const struct vx_bake_params *params; /* the model's parameters (vx_model.params), by index */
} vx_voxel;

struct voxel_grid;

#ifndef __OPENCL_VERSION__
/* Where a record read back from a .vox file sits, for validate_record. */
typedef struct {
    int level;       /* its MIP level (0 for models without levels) */
    float cell_size; /* edge length of that level's cells (world units) */
    int rays;        /* sample rays per voxel of the bake (a bound on any per-voxel sample count) */
} vx_record_context;

/* The interface version a model was written against: the registry refuses a model built for
 * another (tests/unit_models.c checks every registered model). Bump it when a field's meaning
 * changes, so that an out-of-tree model fails loudly instead of rendering garbage. */
#define VX_MODEL_ABI_VERSION 7 /* 7: vx_param.is_switch */

/* A portable evaluation function as both backends see it: the C function and its name in the
 * model's portable source, which the OpenCL program calls (OpenCL C has no function pointers).
 * Declare it with VX_PORTABLE(function) so that the two cannot name different functions. */
#define VX_PORTABLE(fn) {fn, #fn}
typedef struct {
    float (*fn)(VX_GLOBAL const void *record, const vx_query *q);
    const char *name;
} vx_opacity_fn;
typedef struct {
    void (*fn)(VX_GLOBAL const void *record, const vx_query *q, vx_answer *a);
    const char *name;
} vx_shade_fn;
typedef struct {
    void (*fn)(const vx_query *q, vx_answer *a);
    const char *name;
} vx_cone_element_fn;
typedef struct {
    float (*fn)(VX_GLOBAL const void *record, float opacity, float transmittance);
    const char *name;
} vx_transmit_fn;

#define VX_VIEW_TILE_MAX_PIXELS 16 /* vx_voxel_eval.view_tile_pixels' bound: the direction within 11 pixels */

/* Protocol 1, voxel evaluation: the tracer visits the level-0 voxels along each ray (3D-DDA) and
 * composites their answers with `compositing` (VX_COMPOSITE_FIRST_HIT or VX_COMPOSITE_ALPHA). */
typedef struct {
    int compositing;
    const char *source; /* the portable header holding both functions (compiles as OpenCL C) */
    /* Directional opacity along q->ray_dir (for a shadow ray, the direction toward the light). */
    vx_opacity_fn opacity;
    /* Radiance toward q->to_viewer; a->opacity holds the opacity the tracer already computed. */
    vx_shade_fn shade;
    /* 1 when opacity reads only the record and q->ray_dir (not the segment [t0, t1], the footprint
     * or the position): the tracer may then compute a voxel's opacity toward a directional light
     * once and reuse it for every shadow ray (the same number, so the same image). 0 (the safe
     * default): every shadow step asks the model. */
    int opacity_by_direction;
    /* 0 (the default): the opacity of a voxel's answer toward the camera, which the tracer computes
     * once and caches (render_options.cache), is asked along the exact direction between the voxel's
     * centre and the camera. k > 0: along the direction through the centre of the cell, k pixels
     * wide, of a lattice on the image plane that the voxel's centre projects into
     * (tracer/render/view_tile.h): q->ray_dir is then the same for every voxel seen through one cell,
     * and a model whose opacity splits into a part that depends on the direction alone and a part
     * per record (vmesh's views) can do the first once per cell. q->to_viewer, for the shading,
     * stays exact. The direction turns by at most k / sqrt(2) pixels' angle;
     * render_options.view_tiles = 0 (`render --exact-view`) turns it off. At most
     * VX_VIEW_TILE_MAX_PIXELS. (ABI 6.) */
    int view_tile_pixels;
    /* Optional (fn NULL: the exponential rule T (1 - opacity)), alpha compositing only: the
     * transmittance behind the voxel for a ray that reaches it with transmittance `transmittance`,
     * `opacity` being what `opacity` answered (the fraction a ray arriving unattenuated loses).
     * For models whose attenuation depends on what the ray already crossed, as Vicini et al.
     * 2021's non-exponential transmittance does; primary and shadow rays both use it, and the
     * colour is weighted by the transmittance the voxel removes. */
    vx_transmit_fn transmit;
} vx_voxel_eval;

/* Protocol 2, cone evaluation: the tracer steps cone elements (length = diameter) along each ray,
 * the MIP level following the cone's width, and composites the elements' coverage masks A-buffer
 * style (VX_COMPOSITE_COVERAGE); shadows march light cones the same way. The record has levels. */
typedef struct {
    const char *source; /* the portable header holding `element` */
    /* The answer of the element described by q (position, level, footprint, to_viewer, lights),
     * looked up in q->grid / q->records, with q->table the table below. */
    vx_cone_element_fn element;
    /* Optional (may be NULL): a constant table the element reads through q->table (e.g.
     * precomputed masks), built once per process on the host, outside every render timer; the C
     * backend hands it over, OpenCL uploads it as a buffer. Returns the table and its bytes. */
    const void *(*table)(size_t *bytes);
} vx_cone_eval;

/* A model parameter (`--param name=value` on bake): a number with a default and a range. A bake
 * with an unknown name, or a value out of range, is refused; the values a bake used are written
 * into the .vox header. */
typedef struct {
    const char *name;
    double fallback; /* the default */
    double min, max;
    const char *doc; /* one line: what it changes */
    /* 1: a switch, off or on: only 0 and 1 are accepted (range [0, 1], default 0 or 1). Without it a
     * value between, such as 0.5, would pass the range check and be read as whichever side the
     * model's own test (> 0.5) puts it: a bake labelled with a setting it did not use. */
    int is_switch;
} vx_param;
#define VX_MAX_PARAMS 8

struct vx_bake_params {
    double value[VX_MAX_PARAMS]; /* in the order of vx_model.params */
};

/* One record put into a voxel by a moving object (vx_model.combine). */
typedef struct vx_record_part {
    const void *record;
    /* The fraction of the voxel it covers, > 0: 1 for a record placed whole (nearest, or a static
     * one); split8's trilinear weight for one of the 8 neighbours of its centre. */
    float weight;
    /* Its centre (after the motion) minus the voxel's centre, in voxel edges (each within about
     * [-1, 1]): the sub-voxel position a nearest or split placement rounds away. 0 for a static
     * record. */
    float offset[3];
} vx_record_part;

typedef struct vx_model {
    int abi_version; /* VX_MODEL_ABI_VERSION */
    const char *name;
    const char *description;
    /* The per-voxel record. */
    struct {
        size_t bytes;       /* one record */
        int layout_version; /* written into .vox and checked on load: bump it when the layout changes */
        /* 0: one record per non-empty level-0 voxel. 1: records for every MIP level too, level 0
         * first, then level 1, ... (each level's records in its dense-index order); bake_voxel
         * fills level 0 and bake_finish the coarser levels. */
        int levels;
    } record;
    /* Optional (NULL-terminated by name; may be NULL): the model's parameters. */
    const vx_param *params;
    /* Fills the record `out` (record.bytes, zeroed) from the voxel's n sample rays. Called from
     * several threads at once, for different voxels. */
    void (*bake_voxel)(const vx_voxel *v, const vx_sample *samples, int n, void *out);
    /* Optional (may be NULL): runs once after every voxel is baked, with the whole grid and all
     * records (see record.levels). Returns 0, or -1 on failure. */
    int (*bake_finish)(const struct voxel_grid *g, void *records, const struct vx_bake_params *p);
    /* Optional (may be NULL): states what a record may hold, for records read from a .vox file
     * (a checksum only guards against accidents; a crafted or buggy file must not reach the
     * evaluation with NaN, infinities or out-of-range codes). Returns 0 when the record is one the
     * bake could have written, else writes "FIELD: what is wrong" into why and returns -1. */
    int (*validate_record)(const void *record, const vx_record_context *c, char *why, size_t why_size);
    /* Exactly one evaluation protocol; the other is NULL. */
    const vx_voxel_eval *voxel;
    const vx_cone_eval *cone;
    /* Optional, both or neither (ABI 4, offsets and levels ABI 5): moving records, for
     * animated scenes whose objects are baked once and transformed every frame instead of re-baked
     * (tracer/dynamic/, the dynamic-SVO paper's voxel transformation). Without them a moving object
     * is re-baked every frame, and the render says so. Moved level-0 records are not passed through
     * bake_finish again unless the model has levels (a model whose level-0 grid pass matters should
     * not declare these).
     * transform: `out` (record.bytes) is `in` seen after the rotation R (row-major 3x3, proper
     * orthogonal): normals, directional distributions and the like rotated. R exactly the identity
     * must give `in` bit for bit.
     * combine: one record `out` standing for the n >= 1 parts put into one voxel (vx_record_part:
     * each a record, the fraction of the voxel it covers and where its centre lies; ABI 5 added the
     * offset, which models with a position inside the voxel use: a plane's height, a subgrid).
     * Static and moving records meeting in one voxel have weight 1 and offset 0 each; voxel_size
     * is the voxel's edge (world units, for records holding lengths). One part with weight 1 and
     * offset 0 must give its record bit for bit.
     * Models with record.levels: the coarser levels of a frame are rebuilt by bake_finish from the
     * moved level 0 (bake_finish must need nothing but the level-0 records). */
    void (*transform)(const void *in, const float R[9], void *out);
    void (*combine)(const struct vx_record_part *parts, int n, float voxel_size, void *out);
} vx_model;

/* The compositing rule the tracer applies to model m's answers (VX_COMPOSITE_*). */
static inline int vx_model_compositing(const vx_model *m)
{
    return m->cone ? VX_COMPOSITE_COVERAGE : m->voxel->compositing;
}

/* The portable header of m's evaluation (the OpenCL program includes it). */
static inline const char *vx_model_source(const vx_model *m)
{
    return m->cone ? m->cone->source : m->voxel->source;
}

/* The registry (models/registry.c). */
const vx_model *model_find(const char *name);
const vx_model *const *model_all(void); /* NULL-terminated */
/* 0 when m keeps the interface's rules (ABI version, exactly one protocol with its functions and
 * source, a compositing rule the protocol allows, levels for cones, parameters with defaults in
 * range), else -1 with the first broken rule in why. */
int model_check(const vx_model *m, char *why, size_t why_size);
#endif

#endif
