/* Heitz–Neyret's cone element (the model's vx_cone_eval element): the stencil of records around a point
 * on two MIP levels, then the coverage mask and the radiance (hn_eval.h). Portable C: the C model
 * (heitz_neyret.c) and the OpenCL cone kernel (tracer/backends/opencl/cl/render_cone.cl) both call
 * hn_cone_element_eval, the grid's lookups being grid_core.h's and the mask table q->table (a
 * plain array in C, a buffer under OpenCL). */
#ifndef VX_HN_CONE_H
#define VX_HN_CONE_H

#include "floor_int.h"
#include "grid_core.h"
#include "hn_eval.h"

/* Dense indices of cells (x, y, z) and (x, y, z + 1) of level L (-1: empty or outside), for x, y
 * inside the level: the two cells share their column and, but for z % 64 = 63, its word, so the
 * column, the word and its prefix are read once (grid_level_index reads them per cell). */
VX_HOT_INLINE void hn_column_pair(const grid_level *L, int x, int y, int z, int64_t idx[2])
{
    idx[0] = idx[1] = -1;
    uint64_t col = L->cols[(size_t)x * (size_t)L->n + (size_t)y];
    uint32_t mask = (uint32_t)(col & 0xffffu);
    if (!mask)
        return;
    long w_prev = -1;
    uint64_t bits = 0;
    VX_UNROLL
    for (int dz = 0; dz < 2; dz++) {
        int zz = z + dz;
        if ((unsigned)zz >= (unsigned)L->n)
            continue;
        unsigned j = (unsigned)zz >> 6, b = (unsigned)zz & 63u;
        if (!((mask >> j) & 1u))
            continue;
        long w = (long)(col >> 16) + (long)VX_POPCOUNT32(mask & ((1u << j) - 1u));
        if (w != w_prev) {
            bits = L->bits[w];
            w_prev = w;
        }
        if ((bits >> b) & 1u)
            idx[dz] = (int64_t)L->prefix[w] + (int64_t)VX_POPCOUNT64(bits & ((((uint64_t)1) << b) - 1u));
    }
}

/* Level L's 2x2x2 cells around lattice point lat (level-0 units) into st's entries base .. base + 7,
 * marked `slot`, record indices offset by off (the records of the levels below L): in the order x,
 * y, z major to minor (the blends sum in that order), the empty ones too (index -1); a column's two
 * cells are looked up together (hn_column_pair), and the weights' and centres' per-axis factors
 * are computed once (the same expressions, so the same values, as per cell). Returns how many are
 * non-empty, or -1 (nothing written) when lat lies far outside the grid, or is NaN. */
VX_INLINE int hn_fill_level(const voxel_grid *g, const double lat[3], int L, int slot, size_t off, hn_stencil *st,
                            int base)
{
    const grid_level *lev = &g->level[L];
    unsigned n = (unsigned)lev->n;
    double scale = vx_inv_pow2(L), size = g->voxel_size_d * (double)(1u << L);
    int i0[3];
    double wt[3][2];
    float centre[3][2];
    VX_UNROLL
    for (int a = 0; a < 3; a++) {
        double u = lat[a] * scale - 0.5;
        if (!(fabs(u) < 1e9))
            return -1; /* far outside (or NaN): nothing there */
        i0[a] = vx_floor_int(u);
        double f = u - i0[a];
        wt[a][0] = 1 - f;
        wt[a][1] = f;
        for (int d = 0; d < 2; d++)
            centre[a][d] = (float)(g->origin_d[a] + (i0[a] + d + 0.5) * size);
    }
    /* Every cell of the 2x2x2 block goes in, the empty ones (and those outside the grid) with
     * index -1: the edge field (hn_blend_edge) needs a value where there is no surface. */
    int s = base, found = 0;
    VX_UNROLL
    for (int dx = 0; dx < 2; dx++) {
        int in_x = (unsigned)(i0[0] + dx) < n;
        VX_UNROLL
        for (int dy = 0; dy < 2; dy++) {
            int64_t idx[2] = {-1, -1};
            if (in_x && (unsigned)(i0[1] + dy) < n)
                hn_column_pair(lev, i0[0] + dx, i0[1] + dy, i0[2], idx);
            VX_UNROLL
            for (int dz = 0; dz < 2; dz++, s++) {
                st->slot[s] = slot;
                st->weight[s] = (float)(wt[0][dx] * wt[1][dy] * wt[2][dz]);
                st->centre[s] = v3(centre[0][dx], centre[1][dy], centre[2][dz]);
                st->size[s] = (float)size;
                st->index[s] = idx[dz] < 0 ? -1L : (long)(off + (size_t)idx[dz]);
                found += idx[dz] >= 0;
            }
        }
    }
    return found;
}

/* Fills the stencil of the cone element at p (world) and fractional level `level` of grid g:
 * the 8 cells around p on floor(level) (entries 0-7) and on the next level (8-15), with their
 * trilinear weights (the empty ones too, index -1). Record indices count every level's records,
 * level 0 first (vx_model.record.levels). Returns whether any cell is non-empty; when none is, the
 * stencil may be left with no cells (count 0), which the blends of geometry and attributes read as
 * they read 16 empty ones (the edge field is blended only where the geometry found a surface).
 *
 * The coarser level is looked up first: a finer cell is non-empty only inside a non-empty parent,
 * and the finer 2x2x2 cells around p lie inside the coarser 2x2x2 cells around it (per axis, cells
 * i0, i0 + 1 with i0 = floor(u - 1/2) at the finer level, u its lattice coordinate, cover
 * [u - 3/2, u + 3/2), inside the coarser cells' [2 j0, 2 j0 + 4), j0 = floor(u / 2 - 1/2)). So
 * when the coarser ones are all empty, so are the finer, and they are not looked up: a third of
 * the elements a cone meets near a surface are such (bunny 256^3: 187k of 528k). */
VX_INLINE int hn_fill_stencil(const voxel_grid *g, vec3 p, float level, hn_stencil *st)
{
    st->count = 0;
    st->level_frac = 0.0f;
    if (!g || g->levels < 1)
        return 0;
    float lv = vx_fminf(vx_fmaxf(level, 0.0f), (float)(g->levels - 1)); /* NaN -> 0 */
    int L0 = (int)floorf(lv);
    int L1 = L0 + 1 < g->levels ? L0 + 1 : L0;
    st->level_frac = L1 > L0 ? lv - (float)L0 : 0.0f;
    double lat[3];
    grid_to_lattice(g, p, lat);
    size_t off = 0;
    for (int l = 0; l < L0; l++)
        off += g->level[l].count;
    int found1 = 0;
    if (L1 > L0) {
        /* records of level L1 = L0 + 1 follow level L0's */
        found1 = hn_fill_level(g, lat, L1, 1, off + g->level[L0].count, st, 8);
        if (found1 == 0)
            return 0;
    }
    int found0 = hn_fill_level(g, lat, L0, 0, off, st, 0);
    if (found0 < 0)
        return 0; /* far outside: no cells */
    st->count = found1 < 0 || L1 == L0 ? 8 : 16;
    return found0 > 0 || found1 > 0;
}

/* Where the edge is read at the foot (hn_element_edge): the blended normal's length, the cells'
 * unit normals' agreement. Why so close to 1: where the blend mixes faces (a box's corner, the
 * bunny's creases) the top face's plane carried past the side put the foot on empty cells, which
 * cut the element (bunny +20 %, city +12 % at 128^3 reading the foot everywhere; at a 0.97
 * threshold bunny +1.5 %, at 0.99 +1.1 %, at 0.995 nothing). */
#define HN_FLAT_COHERENCE 0.995f

/* The edge field of an element at p of fractional `level` (its stencil st, its blended geometry in
 * s) into s's psi, gpsi and edge. On a flat surface (s->n at least HN_FLAT_COHERENCE long, both
 * levels in st) it is read at the foot of p on the blended plane: psi is an in-plane distance, the
 * same all along the normal, but from an element below a solid's plane by about its radius (one
 * that the layer below the plane still covers) the finer 2x2x2 block misses the empty cells the
 * plane runs through past the edge, or the plane altogether, and the coarser level, twice as coarse
 * and its empty cells at +size/2, placed the edge alone (a plate tilted 20 degrees, 64^2: its near
 * edge +0.81 / +0.89 px at 128^3 / 256^3, MSE 6.7e-4 / 8.6e-4). The foot's field is kept only where
 * its finer level has cells to blend; elsewhere the field is read at p.
 * The foot is tried first, and p's field blended only where the foot gave none: the foot's field
 * replaces all that p's writes (psi, its gradient, edge), and neither read depends on the other
 * (both read only s's normal and distance, which the edge field leaves alone), so the answer is the
 * same as blending p's first; it was thrown away for three quarters of the elements that pass the
 * plane's test (bunny 256^3). Returns whether the foot's stencil was filled into sts (the
 * attributes read it: the same foot, s->n and s->D unchanged since). */
VX_INLINE int hn_element_edge(const voxel_grid *g, VX_GLOBAL const hn_record *records, const hn_stencil *st, vec3 p,
                              float level, hn_sample *s, hn_stencil *sts)
{
    int foot_filled = 0;
    if (sqrtf(v3_dot(s->n, s->n)) > HN_FLAT_COHERENCE && st->count == HN_STENCIL_MAX) {
        vec3 nf = v3_normalize_or(s->n, v3(0.0f, 0.0f, 1.0f));
        vec3 foot = v3_madd(p, nf, -s->D);
        foot_filled = fabsf(s->D) < 1e30f;
        if (foot_filled && hn_fill_stencil(g, foot, level, sts)) {
            hn_sample sf = *s;
            sf.D = 0.0f; /* the foot lies on the plane */
            if (hn_blend_edge(records, sts, foot, &sf)) {
                s->psi = sf.psi;
                s->gpsi = sf.gpsi;
                s->edge = sf.edge;
                return foot_filled;
            }
        }
    }
    hn_blend_edge(records, st, p, s);
    return foot_filled;
}

/* One cone element: geometry and mask at the element's centre; for an element that shows and has
 * lights, the attributes at the foot of the centre on the blended plane (see hn_blend_attributes:
 * they describe the surface, wherever the element sits above or below it). q->table is the mask
 * table (hn_masks.h). */
VX_INLINE void hn_cone_element_eval(const vx_query *q, vx_answer *a)
{
    a->radiance = v3(0.0f, 0.0f, 0.0f);
    a->opacity = 0.0f;
    hn_mask_set(a->mask, 0u);
    if (!q->grid || !q->records || !q->table)
        return;
    VX_GLOBAL const hn_record *records = (VX_GLOBAL const hn_record *)q->records;
    VX_GLOBAL const unsigned int *table = (VX_GLOBAL const unsigned int *)q->table;
    hn_stencil st;
    hn_sample s;
    if (!hn_fill_stencil(q->grid, q->position, q->level, &st) || !hn_blend_geometry(records, &st, q->position, &s))
        return;
    /* An element whose rays the plane alone leaves empty (most of those a cone meets just before a
     * surface) is empty whatever the edge adds: it is known before the edge field (a fifth of the
     * element's cost) is blended, and the answer is the same. */
    float r = vx_fmaxf(q->footprint, 0.0f);
    hn_mask_bounds mb;
    hn_mask_plane(&s, q, r, &mb);
    if (hn_constraints_empty(mb.c, mb.nc, r, mb.behind))
        return;
    hn_stencil sts; /* the foot's stencil, when the edge is read there: the attributes' too */
    int foot_filled = hn_element_edge(q->grid, records, &st, q->position, q->level, &s, &sts);
    vec3 N = hn_mask_finish(table, &s, &mb, r, a);
    if (q->light_count <= 0 || !(a->opacity > 0.0f))
        return;
    vec3 nu = v3_normalize_or(s.n, N);
    vec3 foot = v3_madd(q->position, nu, -s.D);
    if (!(fabsf(s.D) < 1e30f))
        foot = q->position;
    /* The same foot as the edge's read above when there was one (s.n long enough that both
     * normalisations agree, s.D unchanged since): its stencil serves as filled, whatever the fill
     * returned (an empty one reads as one). */
    if (!foot_filled)
        hn_fill_stencil(q->grid, foot, q->level, &sts);
    hn_blend_attributes(records, &sts, foot, nu, &s);
    /* Point lights from the foot, where the surface is, as the truth lights its hit points: from
     * the element's centre a light lying on the surface would be seen at a slant and at a distance
     * as small as the centre's height, so its 1/d^2 would blow up (a light on the ground lit the
     * elements around it 75x brighter than the truth). The distance is bounded by the element's
     * radius: the element stands for its footprint, over which the irradiance is averaged. */
    vx_query ql = *q;
    for (int i = 0; i < ql.light_count && i < VX_MAX_LIGHTS; i++) {
        float d = q->light_distance[i];
        if (!(d > 0.0f) || !(d < 1e30f))
            continue; /* directional, or unknown */
        vec3 v = v3_add(v3_scale(q->to_light[i], d), v3_sub(q->position, foot));
        float d2 = v3_dot(v, v), r = vx_fmaxf(q->footprint, 0.0f);
        if (!(d2 < 1e30f))
            continue;
        ql.to_light[i] = v3_normalize_or(v, q->to_light[i]);
        ql.irradiance[i] = v3_scale(q->irradiance[i], d * d / vx_fmaxf(d2, vx_fmaxf(r * r, 1e-30f)));
    }
    a->radiance = hn_radiance(&s, N, &ql);
}

#endif
