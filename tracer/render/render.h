/* The voxel tracer: rays from the camera marched front to back through the grid (3D-DDA with
 * empty-space skipping), each non-empty voxel handed to the model, the answers composited by the
 * model's rule. Shadows (when declared) march toward each light through the same voxels with the
 * model's own opacity. Knows models only through models/model.h. */
#ifndef VX_RENDER_H
#define VX_RENDER_H

#include <stdint.h>

#include "grid.h"
#include "image.h"
#include "model.h"
#include "scene.h"
#include "shadow_set.h"

typedef struct {
    int spp; /* jittered rays per pixel, box filter (default 4) */
    int width, height;
    uint64_t seed;
    int threads;         /* 0 = every core */
    int progress;        /* progress on stderr when it is a terminal */
    int cache;           /* cache each voxel's shading and opacity for the direction voxel -> camera */
    size_t cache_slots;  /* the C backend's shading cache's slots; 0 (default): sized by the image
                          * (shading_cache.h); the image is the same for any size */
    int shadow_skip;     /* shadow rays ignore voxels closer than 1.5 voxel sizes (Brito et al. §4) */
    float stop_opacity;  /* stop marching at this accumulated opacity (default 1 - 0.001) */
    int shadow_method;   /* SHADOW_* (shadow_maps_core.h), or -1 (default): the scene's */
    int shadow_res;      /* columns per side of the precomputed shadow maps (0: the method's default) */
    int empty_skip;      /* C backend: primary rays (a few neighbouring pixels' at once) jump the empty space before their DDA
                          * by the grid's distance field (pixel_skip.h); exact: the image is the
                          * same without it */
    int shadow_clip;     /* C backend: shadow rays toward a directional light end past the last voxel in
                          * their way, and light cones past the last cells they could ask about
                          * (shadow_clip.h); exact: the image is the same without it */
    int pixel_bounds;    /* C backend: primary rays walk only between their pixel's depth bounds
                          * (pixel_bounds.h), and camera cones end past the last cells they could
                          * ask about (cone_camera_ends.h), built per frame inside its clock; exact */
    int view_tiles;      /* the cached answers asked along their view tile's direction when the model
                          * asks for it (vx_voxel_eval.view_tile_pixels; default 1); 0: along the exact
                          * direction voxel -> camera (`render --exact-view`). Not exact: the
                          * direction moves by up to k / sqrt(2) pixels' angle */
} render_options;

typedef struct {
    double seconds;           /* the whole render */
    double traversal_seconds; /* marching and compositing (seconds - model_seconds) */
    double model_seconds;     /* inside the model's opacity and shade calls: their share of every
                               * 8th row's time (RENDER_TIMED_ROW_STRIDE) times seconds */
    double setup_seconds;     /* the marcher's set-up before the clock (its prepare: the caches, the
                               * distance field, the shadow rays' ends, the cone marcher's bitmaps;
                               * OpenCL's buffers, uploads and clears): per render, outside
                               * `seconds`, as the truth's BVH is outside its own */
    uint64_t rays, shadow_rays, voxel_visits, model_evals, cache_hits;
    uint64_t memo_hits;       /* shadow steps answered by the directional lights' opacity memo */
    shadow_stats shadows;     /* the shadow method, its precomputation (outside `seconds`), its queries */
    long page_faults;         /* the process's minor page faults during `seconds` (getrusage): memory
                               * first touched by the render threads (issue 15; tests/unit_render.c) */
    size_t cache_bytes;       /* the marcher's caches: the shading cache and the shadow opacity memo,
                               * or the cone marcher's light cache */
    size_t map_bytes;         /* the C backend's maps: the pixels' depth bounds (pixel_bounds.h), the
                               * shadow rays' and light cones' ends (shadow_clip.h) and the camera
                               * cones' ends (cone_camera_ends.h) */
} render_counts;

void render_default_options(render_options *o);

/* The directional lights' opacity memo's slots per voxel (shadow_memo.h), the one condition for
 * both backends: shadows declared and marched (maps NULL: none precomputed) toward a directional
 * light, through a model whose opacity depends on the direction alone; then one slot per light
 * (at most VX_MAX_LIGHTS), else 0: no memo. */
int render_shadow_memo_lights(const scene *s, const vx_model *m, const shadow_set *maps);

/* The view tiles in effect, in pixels (tracer/render/view_tile.h), the one condition for both
 * backends and --stats: the model's view_tile_pixels when it evaluates per voxel and the render
 * caches its answers with view tiles on; else 0, the exact direction. */
int render_view_tile_pixels(const vx_model *m, const render_options *o);

int render_image(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                 const render_options *o, image *out, render_counts *counts, vx_err *e);

/* Nonzero (e says why) when the shadow method o asks for (or s declares) does not apply to m: the
 * voxel method to a cone model. Both backends ask before anything else. */
int render_shadow_method_refused(const scene *s, const vx_model *m, const render_options *o, vx_err *e);

/* The `voxel` shadow method's precomputation alone (render_voxel_core.h's voxel_precompute_shadows,
 * on the C tracer's threads), for a backend that reads it back (the OpenCL host uploads it): every
 * level-0 voxel's transmittance toward every light (the scene declaring shadows), at
 * [voxel * lights + light], lights = min(light_count, VX_MAX_LIGHTS); *T is the caller's to free.
 * *seconds: the precomputation's time, as the C backend reports it (the memo and the shadow rays'
 * ends that its march needs, made first, are left out), so both backends report the same work. */
int render_voxel_shadows(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                         const render_options *o, float **T, size_t *bytes, double *seconds, vx_err *e);

#endif
