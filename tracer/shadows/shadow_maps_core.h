/* Precomputed shadows (issue 18): the light-space slicemaps of Eisemann & Décoret 2006 (§2, §3.1)
 * and their query, as portable C: the C marchers (render_voxel_core.h, render_cone_core.h), the
 * ground truth and the OpenCL kernels all run this code, so the backends read the same cells.
 *
 * Per light, a grid of res x res columns seen from the light (directional: orthographic; point: a
 * perspective frustum around the scene), each column cut into `slices` cells along the light's
 * direction and stored as `words` 64-bit words, one bit per cell, the bit of the cell nearest the
 * light lowest (the paper's 32-bit RGBA pixel generalised to any multiple of 64 slices). A set bit
 * is a cell that attenuates the light; `T` holds, for the k-th set bit of a column (in order from
 * the light), the transmittance from the light through that cell, and `prefix` per word the index
 * in T of the word's first set bit, so that the query is the paper's "mask the bits beyond the
 * point, popcount" and one lookup:
 *     rank = prefix[word] + popcount(bits[word] & below(point's slice)),  T = T[rank - 1] (1 if none).
 * With one σ for every cell (the paper's foliage) T[k] = (1 - σ)^(k+1), i.e. (1 - σ)^n; a model's
 * own opacity or several materials just give other products. `opaque` (when has_opaque) is the
 * paper's standard shadow map for solid materials: per column the depth of the first opaque
 * surface; a point behind it is in shadow whatever the bits say.
 *
 * Cells closer to the point than `skip` (the caller's self-shadowing offset, at least the map's own
 * bias) are not counted, as the voxel marcher skips the voxels next to the shaded one.
 *
 * The map's arrays live in one block (the host's shadow_set, an OpenCL buffer): bits (uint64), then
 * prefix (uint32), then T and opaque (floats); each map's params hold its offsets, in elements. */
#ifndef VX_SHADOW_MAPS_CORE_H
#define VX_SHADOW_MAPS_CORE_H

#include "grid_core.h"
#include "light.h"
#include "model.h"

/* Shadow methods (`--shadows`, a scene's "shadows": {"method"}). */
/* SHADOW_VOXEL builds no map: the voxel marcher precomputes the march's transmittance per voxel
 * (render_voxel_core.h's voxel_precompute_shadows). */
enum { SHADOW_MARCH = 0, SHADOW_SLICEMAP = 1, SHADOW_SLICEMAP_MODEL = 2, SHADOW_VOXEL = 3 };

/* One light's map. Only types that C on x86-64 and OpenCL C lay out alike (it travels inside the
 * OpenCL kernels' parameter blocks): 64-bit integers first, then 4-byte fields. */
typedef struct {
    uint64_t bits_off;   /* this map's first word in bits and prefix */
    uint64_t T_off;      /* its first value in T */
    uint64_t opaque_off; /* its first column in opaque */
    int type;            /* LIGHT_DIRECTIONAL (orthographic) or LIGHT_POINT (perspective) */
    int res;             /* columns per side */
    int words;           /* 64-bit words per column */
    int slices;          /* cells per column (words * 64) */
    int has_opaque;      /* 1: the opaque shadow map is there (slicemap); 0: only the bits */
    vec3 origin;         /* the point light's position (perspective maps) */
    vec3 u, v, w;        /* light space: w points away from the light, u and v across */
    float u0, v0;        /* the columns' lower edges (world units; tangents for a frustum) */
    float inv_du, inv_dv; /* columns per unit of u and v */
    float w0;            /* depth of the near plane: along w (orthographic), distance (perspective) */
    float inv_dw;        /* slices per unit depth */
    float bias;          /* the smallest skip: a slice (and 1.5 columns with the opaque map), so that
                            a surface does not shadow its own cell */
} shadow_map_params;

/* Every light's map (the set of a render) and the method that made them; method SHADOW_MARCH and
 * count 0 when there is none. */
typedef struct {
    int method;
    int count; /* maps: one per light, in the scene's order */
    shadow_map_params map[VX_MAX_LIGHTS];
} shadow_maps_params;

/* What a query reads, and its counter (one per thread or work-item). */
typedef struct {
    VX_GLOBAL const shadow_maps_params *p; /* NULL: no precomputed shadows (march) */
    VX_GLOBAL const uint64_t *bits;
    VX_GLOBAL const uint32_t *prefix;
    VX_GLOBAL const float *T;
    VX_GLOBAL const float *opaque;
    uint64_t queries;
} shadow_maps;

/* Whether shadows come from the maps instead of marching. */
VX_INLINE int shadow_maps_active(const shadow_maps *sm)
{
    return sm->p != 0 && sm->p->method != SHADOW_MARCH;
}

VX_INLINE int shadow_popcount64(uint64_t x)
{
    return VX_POPCOUNT32((uint32_t)x) + VX_POPCOUNT32((uint32_t)(x >> 32));
}

/* Column and depth of point p in map m: 0 when p lies outside the map's columns (or behind a
 * point light), which no occluder of the scene can shadow. */
VX_INLINE int shadow_map_locate(VX_GLOBAL const shadow_map_params *m, vec3 p, int64_t *col, float *depth)
{
    float a, b, d;
    if (m->type == LIGHT_POINT) {
        vec3 q = v3_sub(p, m->origin);
        float z = v3_dot(q, m->w);
        if (!(z > 0.0f))
            return 0;
        float iz = 1.0f / z;
        a = v3_dot(q, m->u) * iz;
        b = v3_dot(q, m->v) * iz;
        d = sqrtf(v3_dot(q, q)) - m->w0;
    } else {
        a = v3_dot(p, m->u);
        b = v3_dot(p, m->v);
        d = v3_dot(p, m->w) - m->w0;
    }
    float fi = floorf((a - m->u0) * m->inv_du), fj = floorf((b - m->v0) * m->inv_dv);
    float n = (float)m->res;
    if (!(fi >= 0.0f && fi < n && fj >= 0.0f && fj < n))
        return 0;
    *col = (int64_t)fj * (int64_t)m->res + (int64_t)fi;
    *depth = d;
    return 1;
}

/* Transmittance from p toward light li: the opaque map, then the transmitting cells strictly in
 * front of p's (depth - skip), counted by popcount (Eisemann & Décoret §3.1). */
VX_INLINE float shadow_maps_transmittance(shadow_maps *sm, int li, vec3 p, float skip)
{
    VX_GLOBAL const shadow_map_params *m = &sm->p->map[li];
    sm->queries++;
    int64_t col;
    float d;
    if (li >= sm->p->count || !shadow_map_locate(m, p, &col, &d))
        return 1.0f;
    d -= vx_fmaxf(skip, m->bias);
    if (m->has_opaque && sm->opaque[m->opaque_off + (uint64_t)col] < d)
        return 0.0f;
    float fs = floorf(d * m->inv_dw);
    if (!(fs > 0.0f))
        return 1.0f;
    int s = fs < (float)m->slices ? (int)fs : m->slices;
    uint64_t w0 = m->bits_off + (uint64_t)col * (uint64_t)m->words;
    int k = s >> 6, r = s & 63;
    uint32_t rank;
    if (k >= m->words) /* every cell of the column lies in front */
        rank = sm->prefix[w0 + (uint64_t)(m->words - 1)] + (uint32_t)shadow_popcount64(sm->bits[w0 + (uint64_t)(m->words - 1)]);
    else
        rank = sm->prefix[w0 + (uint64_t)k] +
               (uint32_t)shadow_popcount64(sm->bits[w0 + (uint64_t)k] & ((((uint64_t)1) << r) - 1u));
    if (rank == sm->prefix[w0])
        return 1.0f;
    return sm->T[m->T_off + (uint64_t)(rank - 1u)];
}

/* The skip of a query from a voxel's centre (the voxel marcher): the voxels closer than 1.5 voxel
 * sizes with shadow_skip (Brito et al. §4, as the march skips them), else the voxel's own extent. */
VX_INLINE float shadow_maps_voxel_skip(float voxel_size, int shadow_skip)
{
    return (shadow_skip ? 1.5f : 0.8660254f) * voxel_size;
}

#endif
