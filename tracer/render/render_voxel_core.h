/* Voxel marching for models with per-voxel evaluation (vx_voxel_eval), as portable C: the C tracer
 * (render_voxel.c) and the OpenCL kernel (backends/opencl/cl/render.cl) both run this code, so the
 * two backends cannot drift apart.
 *
 * Each pixel's rays (stratified jittered samples, the ground truth's strata.h; lens samples with
 * depth of field) are marched front to back through the level-0 voxels (grid_traverse_core.h's
 * DDA); each non-empty voxel is handed to the model (opacity, then shade with the lights gathered
 * when the voxel is not transparent) and the answers are composited by the model's rule: first hit
 * or front-to-back alpha. Shadows (when the scene declares them) march toward each light through
 * the same voxels with the model's own opacity, skipping the voxel itself and, with shadow_skip,
 * the voxels closer than 1.5 voxel sizes (Brito et al. §4).
 *
 * With the shading cache, a voxel is evaluated once, for the direction voxel -> camera, by the
 * first ray that visits it; the answer depends only on the voxel, so whoever computes it writes the
 * same numbers and the image does not depend on the order in which threads or work-items run.
 *
 * The includer defines, before including this file:
 *   VOXEL_OPACITY(x, rec, q)      the model's opacity (a function pointer call in C, the model's
 *                                 portable function by name in OpenCL C, which has no pointers)
 *   VOXEL_SHADE(x, rec, q, a)     the model's shade
 *   VOXEL_COMPOSITING(x)          the model's VX_COMPOSITE_* rule (a constant in an OpenCL program)
 *   VOXEL_CACHE_GET(x, index, a)  1 with voxel `index`'s cached answer in *a when it is ready, else 0
 *   VOXEL_CACHE_PUT(x, index, a)  publishes *a as that voxel's answer (the first writer wins)
 * It may define
 *   VOXEL_PIXEL_SKIP(x, org, dirs, n)  a t before which none of n rays (one origin: one pixel's or a
 *                                 few neighbouring pixels', see voxel_render_span) meets a non-empty
 *                                 voxel, and VOXEL_SKIP_GROUP, the most rays asked at once (an exact
 *                                 skip: the walks from there visit the same cells);
 * and VOXEL_BOUNDS_ACTIVE(x) with VOXEL_RAY_BOUNDS(x, px, py, dir, &t_min, &t_max): when the first
 *                                 is true, the second narrows a primary ray of pixel (px, py) to the
 *                                 interval where it can meet a non-empty voxel (the C backend's
 *                                 pixel_bounds.h; exact, and the skip is then not asked for), and
 *                                 VOXEL_PIXEL_EMPTY(x, px, py), 1 when it would narrow every ray of
 *                                 the pixel to nothing (its rays are then not made: the pixel is
 *                                 the background, as they would make it), and it may define
 *                                 VOXEL_NEXT_SPAN(x, &t_min, &t_max): 1 with the next interval of the
 *                                 ray last narrowed by VOXEL_RAY_BOUNDS after the one walked (the
 *                                 C backend's depth slabs: none of the ray's non-empty cells lies
 *                                 between the two), 0 when there is none;
 * and, for a model with vx_voxel_eval.transmit,
 *   VOXEL_HAS_TRANSMIT(x)          1 when the model declares transmit
 *   VOXEL_TRANSMIT(x, rec, a, T)   the transmittance behind the voxel of opacity a reached with T
 * (without them, the exponential rule T (1 - a), written as it always was),
 * and may add its own fields to voxel_ctx through VOXEL_CTX_BACKEND_FIELDS (the cache's memory, the
 * C backend's model timer). It may define
 *   VOXEL_SHADOW_END(x, light, o, dir, t_max)  a t at or before t_max past which the shadow ray
 *                                 from o (level-0 lattice units) along dir toward light `light` meets
 *                                 no non-empty voxel (the C backend's shadow_clip.h; exact: the walk
 *                                 to there reports the same cells with the same [t0, t1]);
 * and VOXEL_SHADOW_DIRECTION(x, light, dir): light `light`'s direction dir prepared for the walk
 *                                 (gt_direction_prepare at level 0) once for all its shadow rays, or
 *                                 NULL (prepared per ray);
 * and VOXEL_PREFETCH_RECORD(x, index): a hint that voxel `index`'s record is about to be read
 * (the C backend's prefetch; nothing else may depend on it);
 * and VOXEL_SHADOW_PRECOMPUTED(x, index, light): voxel `index`'s transmittance toward light `light`
 *                                 as voxel_precompute_shadows computed it before the frame (the
 *                                 `voxel` shadow method), or a negative number when there is none;
 * and it may also define
 *   VOXEL_SHADOW_MEMO(x, index, light, q)  voxel `index`'s opacity toward directional light
 *                                 `light`, asked of the model with query q once and then remembered;
 *                                 used only when the model declares opacity_by_direction (the number
 *                                 is then the same whoever computes it, so the image is unchanged). */
#ifndef VX_RENDER_VOXEL_CORE_H
#define VX_RENDER_VOXEL_CORE_H

#include "camera.h"
#include "floor_int.h"
#include "grid_traverse_core.h"
#include "light.h"
#include "model.h"
#include "rng.h"
#include "shadow_maps_core.h"
#include "strata.h"
#include "view_tile.h"

#if !defined(VOXEL_OPACITY) || !defined(VOXEL_SHADE) || !defined(VOXEL_COMPOSITING) || !defined(VOXEL_CACHE_GET) || \
    !defined(VOXEL_CACHE_PUT)
#error "define VOXEL_OPACITY, VOXEL_SHADE, VOXEL_COMPOSITING, VOXEL_CACHE_GET and VOXEL_CACHE_PUT first"
#endif
#ifndef VOXEL_CTX_BACKEND_FIELDS
#define VOXEL_CTX_BACKEND_FIELDS
#endif
/* Empty-space skipping for a pixel's primary rays (the C backend's pixel_skip.h): by default none,
 * one ray at a time (the OpenCL kernel keeps its registers). */
#ifndef VOXEL_PIXEL_SKIP
#define VOXEL_PIXEL_SKIP(x, org, dirs, n) 0.0f
#define VOXEL_SKIP_GROUP 1
#endif
#ifndef VOXEL_RAY_BOUNDS
#define VOXEL_BOUNDS_ACTIVE(x) 0
#define VOXEL_RAY_BOUNDS(x, px, py, dir, t_min, t_max)
#define VOXEL_PIXEL_EMPTY(x, px, py) 0
#endif
#ifndef VOXEL_NEXT_SPAN
#define VOXEL_NEXT_SPAN(x, t_min, t_max) 0
#endif
#ifndef VOXEL_SHADOW_DIRECTION
#define VOXEL_SHADOW_DIRECTION(x, light, dir) ((const gt_direction *)0)
#endif
#ifndef VOXEL_SHADOW_END
#define VOXEL_SHADOW_END(x, light, o, dir, t_max) (t_max)
#endif
#ifndef VOXEL_SHADOW_PRECOMPUTED
#define VOXEL_SHADOW_PRECOMPUTED(x, index, light) (-1.0f)
#endif
#ifndef VOXEL_PREFETCH_RECORD
#define VOXEL_PREFETCH_RECORD(x, index)
#endif
#ifndef VOXEL_HAS_TRANSMIT
#define VOXEL_HAS_TRANSMIT(x) 0
#define VOXEL_TRANSMIT(x, rec, a, T) ((T) * (1.0f - (a)))
#endif

/* What a march counts (render statistics). */
typedef struct {
    uint64_t rays, shadow_rays, visits, evals, cache_hits;
    uint64_t memo_hits; /* shadow steps answered by VOXEL_SHADOW_MEMO without asking the model */
} voxel_counts;

/* Everything a march reads, and the counters it adds to: one per thread (C) or work-item (OpenCL). */
typedef struct voxel_ctx {
    const voxel_grid *g;
    VX_GLOBAL const unsigned char *records;
    size_t record_bytes;
    camera cam;
    vec3 background;
    light lights[VX_MAX_LIGHTS];
    int light_count;
    unsigned effects;   /* VX_EFFECT_* */
    float spread;       /* footprint radius per unit distance (camera_pixel_spread) */
    float stop_opacity; /* stop marching at this accumulated opacity */
    int shadow_skip;
    int cache;
    int cam_cell[3];          /* the camera's level-0 cell (voxel_set_camera_cell): its neighbours are not cached */
    double cam_lattice[3];    /* the camera in level-0 lattice units (gt_lattice_point), for the rays from it */
    int opacity_by_direction; /* the model's vx_voxel_eval.opacity_by_direction */
    float view_tile;          /* the cached opacities' direction lattice (view_tile.h); 0: the exact direction */
    shadow_maps shadows;      /* precomputed shadows (shadow_maps_core.h); p NULL: march */
    voxel_counts counts;
    VOXEL_CTX_BACKEND_FIELDS
} voxel_ctx;

VX_INLINE VX_GLOBAL const void *voxel_record(const voxel_ctx *x, int64_t index)
{
    return (VX_GLOBAL const void *)(x->records + (size_t)index * x->record_bytes);
}

/* Transmittance from p toward light li through the voxels (the model's own opacity), skipping the
 * voxel `self` and, with shadow_skip, every voxel closer than 1.5 voxel sizes. memo: the light is
 * directional and the model's opacity depends on the direction only (VOXEL_SHADOW_MEMO). */
VX_INLINE float voxel_shadow_transmittance(voxel_ctx *x, const vx_query *q, int64_t self, vec3 p, vec3 to_light,
                                           float distance, int li, int memo)
{
    const voxel_grid *g = x->g;
    float t_min = x->shadow_skip ? 1.5f * g->voxel_size : 0.0f;
    grid_iter it;
    grid_hit h;
    float T = 1.0f;
    x->counts.shadow_rays++;
    /* p mapped once, for the walk and its end; the direction prepared once a light where the
     * backend keeps it. The same numbers as gt_iter_init's, so the same walk. */
    double o[3];
    gt_lattice_point(g, 0, p, o);
    gt_direction own;
    const gt_direction *pd = VOXEL_SHADOW_DIRECTION(x, li, to_light);
    if (!pd) {
        gt_direction_prepare(g, 0, to_light, &own);
        pd = &own;
    }
    if (!gt_iter_init_prepared(&it, g, 0, o, pd, t_min, VOXEL_SHADOW_END(x, li, o, to_light, distance)))
        return 1.0f;
    vx_query sq = *q;
    sq.ray_origin = p;
    sq.ray_dir = to_light;
    sq.to_viewer = v3_scale(to_light, -1.0f);
    while (gt_iter_next(&it, &h)) {
        if (h.index == self)
            continue;
        float a;
#ifdef VOXEL_SHADOW_MEMO
        if (memo) {
            a = VOXEL_SHADOW_MEMO(x, h.index, li, &sq);
        } else
#endif
        {
            (void)li, (void)memo;
            sq.t0 = h.t0;
            sq.t1 = h.t1;
            vec3 hi;
            grid_cell_corners(g, 0, h.x, h.y, h.z, &sq.voxel_lo, &hi);
            a = VOXEL_OPACITY(x, voxel_record(x, h.index), &sq);
        }
        a = vx_fminf(vx_fmaxf(a, 0.0f), 1.0f);
        if (VOXEL_HAS_TRANSMIT(x))
            T = VOXEL_TRANSMIT(x, voxel_record(x, h.index), a, T);
        else
            T *= 1.0f - a;
        if (T < 1e-4f)
            return 0.0f;
    }
    return T;
}

/* The transmittance toward light li (direction dir, at distance dist) of voxel `self` centred at c,
 * the scene declaring shadows: the precomputed maps', the `voxel` method's precomputation
 * (VOXEL_SHADOW_PRECOMPUTED), or a shadow ray marched now. */
VX_INLINE float voxel_light_transmittance(voxel_ctx *x, const vx_query *q, int64_t self, vec3 c, vec3 dir, float dist,
                                          int li)
{
    if (shadow_maps_active(&x->shadows))
        return shadow_maps_transmittance(&x->shadows, li, c, shadow_maps_voxel_skip(x->g->voxel_size, x->shadow_skip));
    float T = VOXEL_SHADOW_PRECOMPUTED(x, self, li);
    if (T >= 0.0f)
        return T;
    return voxel_shadow_transmittance(x, q, self, c, dir, dist, li, x->opacity_by_direction && !(dist < INFINITY));
}

/* Fills q's lights for a voxel centred at c (shadows applied when declared). T_out, when not NULL,
 * receives each light's transmittance (voxel_precompute_shadows). */
VX_INLINE void voxel_gather_lights(voxel_ctx *x, vx_query *q, int64_t self, vec3 c, float *T_out)
{
    q->light_count = x->light_count;
    for (int li = 0; li < q->light_count; li++) {
        vec3 dir, irr;
        float dist;
        light_at(&x->lights[li], c, &dir, &irr, &dist);
        if (x->effects & VX_EFFECT_SHADOWS) {
            float T = voxel_light_transmittance(x, q, self, c, dir, dist, li);
            irr = v3_scale(irr, T);
            if (T_out)
                T_out[li] = T;
        }
        q->to_light[li] = dir;
        q->irradiance[li] = irr;
    }
}

/* The model's answer for one voxel along q (opacity; radiance only where it is not transparent). */
VX_INLINE void voxel_evaluate(voxel_ctx *x, vx_query *q, int64_t index, vec3 centre, vx_answer *a)
{
    VX_GLOBAL const void *rec = voxel_record(x, index);
    a->opacity = VOXEL_OPACITY(x, rec, q);
    a->radiance = v3(0.0f, 0.0f, 0.0f);
    x->counts.evals++;
    if (!(a->opacity > 0.0f))
        return;
    voxel_gather_lights(x, q, index, centre, NULL);
    VOXEL_SHADE(x, rec, q, a);
}

/* The query every voxel starts from: zeroed, with the voxel's box, size and the scene's effects. */
VX_INLINE void voxel_query(const voxel_ctx *x, const grid_hit *h, vx_query *q, vec3 *centre)
{
    vx_query zero = {0};
    *q = zero;
    vec3 hi;
    grid_cell_corners(x->g, 0, h->x, h->y, h->z, &q->voxel_lo, &hi);
    *centre = v3_scale(v3_add(q->voxel_lo, hi), 0.5f);
    q->voxel_size = x->g->voxel_size;
    q->effects = x->effects;
}

/* The query of a cached evaluation of the voxel h: the direction from its centre toward the camera
 * (dir, the ray's, only where the two coincide); the opacity's, with the model's view tiles, from
 * its view tile's centre (view_tile.h). */
VX_INLINE void voxel_cached_query(const voxel_ctx *x, const grid_hit *h, vec3 dir, vx_query *q, vec3 *centre)
{
    voxel_query(x, h, q, centre);
    vec3 to_cam = v3_sub(x->cam.position, *centre);
    float dist = v3_length(to_cam);
    q->to_viewer = v3_normalize_or(to_cam, v3_scale(dir, -1.0f));
    q->ray_dir = view_tile_direction(&x->cam, x->view_tile, v3_scale(q->to_viewer, -1.0f));
    q->ray_origin = x->cam.position;
    q->t0 = dist - 0.5f * x->g->voxel_size;
    q->t1 = dist + 0.5f * x->g->voxel_size;
    q->footprint = dist * x->spread;
}

/* x->cam_lattice, and x->cam_cell: the level-0 cell holding the camera, its lattice coordinates
 * clamped to two cells around the grid first (a camera farther out is as far from every voxel as
 * that, and its floor stays an int). */
VX_INLINE void voxel_set_camera_cell(voxel_ctx *x)
{
    double *lat = x->cam_lattice;
    gt_lattice_point(x->g, 0, x->cam.position, lat);
    double hi = (double)x->g->n + 2.0;
    for (int a = 0; a < 3; a++) {
        double u = lat[a] > -2.0 ? (lat[a] < hi ? lat[a] : hi) : -2.0; /* NaN -> -2 */
        x->cam_cell[a] = vx_floor_int(u);
    }
}

/* Whether voxel h lies in the 3x3x3 cells around the camera's. The cache answers a voxel for the
 * one direction from its centre to the camera, which stands for every ray through it only when the
 * voxel is small seen from the camera; from inside it or a cell away the rays through it spread over
 * up to every direction, and the one cached direction may be any of them (the stability audit: a
 * camera 1e-3 above a plate saw vicini's plate 76 % see-through and vmesh's dark, where --no-cache
 * was right). Such voxels are answered per ray. */
VX_INLINE int voxel_near_camera(const voxel_ctx *x, const grid_hit *h)
{
    return (unsigned)(h->x - x->cam_cell[0] + 1) <= 2u && (unsigned)(h->y - x->cam_cell[1] + 1) <= 2u &&
           (unsigned)(h->z - x->cam_cell[2] + 1) <= 2u;
}

/* The voxel's answer: from the cache (for the direction voxel -> camera; not for the voxels around
 * the camera, voxel_near_camera), or as this ray sees it. */
VX_INLINE void voxel_answer(voxel_ctx *x, const grid_hit *h, vec3 org, vec3 dir, vx_answer *a)
{
    vx_query q;
    vec3 centre;
    if (x->cache && !voxel_near_camera(x, h)) {
        /* The record is asked for before the cache's slot is read, so that where both miss (a voxel's
         * first visit, which evaluates it) the two loads overlap instead of one waiting for the other
         * (vmesh's record's first read was a quarter of its opacity's profile, binary's opacity is
         * that read alone). A later visit's record lines are mostly still cached from the first:
         * little traffic for nothing. Measured against asking after the slot (2 threads, medians of
         * interleaved frames): 512^3 with --shadows voxel, vmesh, alpha and binary 3 % faster,
         * vicini the same; 256^3 0.5 to 2.5 %. */
        VOXEL_PREFETCH_RECORD(x, h->index);
        if (VOXEL_CACHE_GET(x, h->index, a)) {
            x->counts.cache_hits++;
            return;
        }
        voxel_cached_query(x, h, dir, &q, &centre);
        voxel_evaluate(x, &q, h->index, centre, a);
        VOXEL_CACHE_PUT(x, h->index, a);
        return;
    }
    voxel_query(x, h, &q, &centre);
    q.to_viewer = v3_scale(dir, -1.0f);
    q.ray_origin = org;
    q.ray_dir = dir;
    q.t0 = h->t0;
    q.t1 = h->t1;
    float tm = 0.5f * (h->t0 + h->t1);
    q.footprint = tm * x->spread;
    if ((x->effects & VX_EFFECT_DOF) && x->cam.aperture_radius > 0.0f)
        q.footprint += x->cam.aperture_radius * fabsf(tm - x->cam.focus_distance) / x->cam.focus_distance;
    voxel_evaluate(x, &q, h->index, centre, a);
}

/* The `voxel` shadow method's precomputation (Brito et al. 2023, §5: "In a precomputation, we cast
 * a shadow ray from a light source toward the center of a voxel"): voxel h's transmittance toward
 * each light, into T[0 .. light_count - 1], computed as voxel_gather_lights computes it for the
 * voxel's cached evaluation (the same query, the same march), so a frame that reads it back has
 * the march's image bit for bit. The frame asks it only of voxels that are not transparent toward
 * the camera; this asks it of every voxel (the frame's voxels are not known before it). x must not
 * have precomputed shadows yet (VOXEL_SHADOW_PRECOMPUTED negative). */
VX_INLINE void voxel_precompute_shadows(voxel_ctx *x, const grid_hit *h, float *T)
{
    vx_query q;
    vec3 centre;
    voxel_cached_query(x, h, x->cam.forward, &q, &centre);
    voxel_gather_lights(x, &q, h->index, centre, T);
}

/* A ray's colour: what it composited (color, opacity A) over the background. */
VX_INLINE vec3 voxel_over_background(const voxel_ctx *x, vec3 color, float A)
{
    return v3_madd(color, x->background, 1.0f - A);
}

/* One ray: the voxels' answers composited front to back over the background. [t_min, t_max]: where
 * its walk starts and ends (VOXEL_PIXEL_SKIP's or VOXEL_RAY_BOUNDS' answer; the ray meets no
 * non-empty voxel outside it). */
VX_INLINE vec3 voxel_trace_ray(voxel_ctx *x, vec3 org, vec3 dir, float t_min, float t_max)
{
    vec3 color = v3(0.0f, 0.0f, 0.0f);
    float A = 0.0f;
    int done = 0;
    grid_iter it;
    grid_hit h;
    x->counts.rays++;
    /* The rays from the camera (all of them without depth of field) start from its lattice point,
     * mapped once; an equal float maps to the same doubles, so the walk is the same. */
    int from_camera = org.x == x->cam.position.x && org.y == x->cam.position.y && org.z == x->cam.position.z;
    /* The walk goes over each span the bounds leave the ray (VOXEL_NEXT_SPAN), in order: no
     * non-empty cell lies between them, so the walks together report the cells of one. The ray's
     * origin and direction are mapped to the lattice once, before its first span that is not empty
     * (gt_iter_init's own steps, so the same walks). An empty [t_min, t_max] (a pixel whose bounds
     * hold no voxel: t_min infinite) has no cells, as gt_iter_init would find after its divisions. */
    while (!(t_min < t_max))
        if (!VOXEL_NEXT_SPAN(x, &t_min, &t_max))
            return voxel_over_background(x, color, A);
    gt_direction pd;
    double o[3];
    gt_direction_prepare(x->g, 0, dir, &pd);
    if (from_camera)
        for (int a = 0; a < 3; a++)
            o[a] = x->cam_lattice[a];
    else
        gt_lattice_point(x->g, 0, org, o);
    do {
        if (!(t_min < t_max && gt_iter_init_prepared(&it, x->g, 0, o, &pd, t_min, t_max)))
            continue;
        while (!done && gt_iter_next(&it, &h)) {
            x->counts.visits++;
            vx_answer a;
            voxel_answer(x, &h, org, dir, &a);
            float alpha = vx_fminf(vx_fmaxf(a.opacity, 0.0f), 1.0f);
            if (!(alpha > 0.0f))
                continue;
            if (VOXEL_COMPOSITING(x) == VX_COMPOSITE_FIRST_HIT) {
                color = a.radiance;
                A = 1.0f;
                done = 1;
            } else if (VOXEL_HAS_TRANSMIT(x)) { /* alpha, with the model's own attenuation */
                float T = 1.0f - A;
                float T_out = vx_fminf(vx_fmaxf(VOXEL_TRANSMIT(x, voxel_record(x, h.index), alpha, T), 0.0f), T);
                color = v3_madd(color, a.radiance, T - T_out);
                A = 1.0f - T_out;
                done = A >= x->stop_opacity;
            } else { /* VX_COMPOSITE_ALPHA */
                color = v3_madd(color, a.radiance, (1.0f - A) * alpha);
                A += (1.0f - A) * alpha;
                done = A >= x->stop_opacity;
            }
        }
    } while (!done && VOXEL_NEXT_SPAN(x, &t_min, &t_max));
    return voxel_over_background(x, color, A);
}

/* Ray k of pixel (px, py): a stratified jittered sample (the ground truth's strata.h), with a lens
 * sample under depth of field, its random numbers drawn from the pixel's stream r in the order of k.
 * strata_x * strata_y = truth_strata(spp). */
VX_INLINE void voxel_pixel_ray(const voxel_ctx *x, rng *r, int k, int px, int py, int width, int height, int strata_x,
                               int strata_y, int dof, vec3 *org, vec3 *dir)
{
    float sx, sy, lu = 0, lv = 0;
    float r1 = rng_float(r), r2 = rng_float(r);
    truth_strata_sample(k, strata_x, strata_y, r1, r2, &sx, &sy);
    if (dof) {
        lu = rng_float(r);
        lv = rng_float(r);
    }
    camera_ray(&x->cam, width, height, (float)px + sx, (float)py + sy, lu, lv, dof, org, dir);
}

/* The box filter's mean of a pixel's spp rays, into dst[0..2]. */
VX_INLINE void voxel_store_mean(VX_GLOBAL float *dst, vec3 sum, int spp)
{
    dst[0] = sum.x / (float)spp;
    dst[1] = sum.y / (float)spp;
    dst[2] = sum.z / (float)spp;
}

/* A pixel whose spp rays meet nothing (VOXEL_PIXEL_EMPTY), into dst[0..2]: the mean of spp
 * background colours summed as voxel_render_span sums its rays' (so the same bits), the rays counted
 * as if made. Bunny's 256^2 frame has 40 % such pixels: making, bounding and ending their rays
 * was 22 million of binary's instructions a frame (7 %). */
VX_INLINE void voxel_empty_pixel(voxel_ctx *x, int spp, VX_GLOBAL float *dst)
{
    vec3 sum = v3(0.0f, 0.0f, 0.0f);
    for (int k = 0; k < spp; k++)
        sum = v3_add(sum, voxel_over_background(x, v3(0.0f, 0.0f, 0.0f), 0.0f));
    x->counts.rays += (uint64_t)spp;
    voxel_store_mean(dst, sum, spp);
}

/* Pixels px .. px + count - 1 of row py of a width x height image, each the box filter's mean of
 * its spp rays (the random stream of the pixel's index, as the ground truth's), into
 * dst[0 .. 3 count - 1].
 *
 * The empty-space skip (VOXEL_PIXEL_SKIP) is shared by as many rays as it can take at once
 * (VOXEL_SKIP_GROUP, one origin, so not under depth of field): all the span's rays when they fit,
 * else each pixel's rays in groups. Neighbouring pixels' rays take nearly the same path to the
 * surface, so one walk for a few pixels costs less than one per pixel for a jump that is only a
 * little shorter (the wider spread). A group's rays are made first, each pixel's random numbers
 * drawn in the same order as one ray at a time, and each pixel adds its rays in their order: the
 * pixels do not depend on the grouping. */
VX_INLINE void voxel_render_span(voxel_ctx *x, uint64_t seed, int px, int count, int py, int width, int height,
                                 int spp, int strata_x, int strata_y, VX_GLOBAL float *dst)
{
    int dof = (x->effects & VX_EFFECT_DOF) != 0;
    vec3 org[VOXEL_SKIP_GROUP], dir[VOXEL_SKIP_GROUP];
    if (!dof && count > 1 && count * spp <= VOXEL_SKIP_GROUP) {
        /* The empty pixels (only where the bounds are active, so never where the skip is asked)
         * make no rays. */
        int empty[VOXEL_SKIP_GROUP];
        for (int p = 0; p < count; p++) {
            empty[p] = VOXEL_PIXEL_EMPTY(x, px + p, py);
            if (empty[p])
                continue;
            rng r = rng_seed(seed, (uint64_t)py * (uint64_t)width + (uint64_t)(px + p));
            for (int k = 0; k < spp; k++)
                voxel_pixel_ray(x, &r, k, px + p, py, width, height, strata_x, strata_y, 0, &org[p * spp + k],
                                &dir[p * spp + k]);
        }
        float t_skip = VOXEL_BOUNDS_ACTIVE(x) ? 0.0f : VOXEL_PIXEL_SKIP(x, org[0], dir, count * spp);
        for (int p = 0; p < count; p++) {
            if (empty[p]) {
                voxel_empty_pixel(x, spp, dst + 3 * p);
                continue;
            }
            vec3 sum = v3(0.0f, 0.0f, 0.0f);
            for (int k = 0; k < spp; k++) {
                float t_min = t_skip, t_max = INFINITY;
                VOXEL_RAY_BOUNDS(x, px + p, py, dir[p * spp + k], &t_min, &t_max);
                sum = v3_add(sum, voxel_trace_ray(x, org[p * spp + k], dir[p * spp + k], t_min, t_max));
            }
            voxel_store_mean(dst + 3 * p, sum, spp);
        }
        return;
    }
    for (int p = 0; p < count; p++) {
        if (!dof && VOXEL_PIXEL_EMPTY(x, px + p, py)) {
            voxel_empty_pixel(x, spp, dst + 3 * p);
            continue;
        }
        rng r = rng_seed(seed, (uint64_t)py * (uint64_t)width + (uint64_t)(px + p));
        vec3 sum = v3(0.0f, 0.0f, 0.0f);
        for (int first = 0; first < spp; first += VOXEL_SKIP_GROUP) {
            int n = spp - first < VOXEL_SKIP_GROUP ? spp - first : VOXEL_SKIP_GROUP;
            for (int k = 0; k < n; k++)
                voxel_pixel_ray(x, &r, first + k, px + p, py, width, height, strata_x, strata_y, dof, &org[k], &dir[k]);
            /* With depth of field the rays leave from different lens points: no shared skip. */
            float t_skip = dof || VOXEL_BOUNDS_ACTIVE(x) ? 0.0f : VOXEL_PIXEL_SKIP(x, org[0], dir, n);
            for (int k = 0; k < n; k++) {
                float t_min = t_skip, t_max = INFINITY;
                if (!dof)
                    VOXEL_RAY_BOUNDS(x, px + p, py, dir[k], &t_min, &t_max);
                sum = v3_add(sum, voxel_trace_ray(x, org[k], dir[k], t_min, t_max));
            }
        }
        voxel_store_mean(dst + 3 * p, sum, spp);
    }
}

/* Pixel (px, py) alone (the OpenCL kernel's work-item). */
VX_INLINE void voxel_render_pixel(voxel_ctx *x, uint64_t seed, int px, int py, int width, int height, int spp,
                                  int strata_x, int strata_y, VX_GLOBAL float *dst)
{
    voxel_render_span(x, seed, px, 1, py, width, height, spp, strata_x, strata_y, dst);
}

#endif
