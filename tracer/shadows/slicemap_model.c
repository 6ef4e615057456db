/* slicemap-model: one light's light-space bit grid filled from a baked model's own occlusion toward
 * the light (issue 18), precomputed once per light instead of marched per shading point. Each
 * column's ray is cast from the far plane toward the light, so that the model is asked exactly as a
 * shadow ray asks it (direction toward the light):
 *  - voxel models (vx_voxel_eval): every voxel the ray crosses (the marcher's DDA) gives its
 *    directional opacity a; the slice of the voxel's midpoint keeps the product of (1 - a), or,
 *    for a model with its own attenuation rule (vx_voxel_eval.transmit: Vicini et al. 2021's
 *    non-exponential transmittance, which depends on the transmittance a ray brings), the rule
 *    applied voxel after voxel from the light's side (the marcher applies it from the shaded point:
 *    the same for the exponential rule, an approximation for a non-exponential one);
 *  - cone models (vx_cone_eval): cone elements as wide as the column (the marcher's light cones),
 *    whose coverage masks are united from the light's side: the slice of an element keeps
 *    1 - covered / 128 after it (masks do not multiply; the union is the cone marcher's rule).
 * The column then keeps, per slice, the transmittance from the light through it (shadow_maps_core.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "grid_traverse_core.h"
#include "parallel.h"
#include "shadow_build_internal.h"

struct cone_ctx;
#define CONE_ELEMENT(x, q, a) (x)->m->cone->element.fn(q, a)
#include "cone_skip.h"
#include "render_cone_core.h"

typedef struct {
    float d;
    unsigned int mask[VX_MASK_WORDS];
} column_element;

typedef struct {
    column_element *e;
    size_t n, cap;
} element_list;

typedef struct {
    float d, a;
    int64_t index;
} column_voxel;

typedef struct {
    column_voxel *v;
    size_t n, cap;
} voxel_list;

typedef struct {
    const scene *s;
    const voxel_grid *g;
    const vx_model *m;
    const unsigned char *records;
    const void *table;
    const dilated_grid *skip;
    map_build *b;
    float *scratch;       /* per thread: 2 * slices floats */
    element_list *lists;  /* per thread (cone models) */
    voxel_list *vlists;   /* per thread (voxel models with transmit) */
    int failed;
} model_job;

/* The column's per-slice transmittance factors (voxel models): the product of (1 - opacity) per
 * slice; with the model's transmit rule, the voxels are listed in L instead (from the far plane). */
static void voxel_column(model_job *j, int i, int jj, float *f, voxel_list *L)
{
    const voxel_grid *g = j->g;
    map_build *b = j->b;
    vec3 org, dir;
    shadow_column_ray(b, i, jj, 1, &org, &dir);
    grid_iter it;
    grid_hit h;
    if (!gt_iter_init(&it, g, 0, org, dir, 0.0f, b->len))
        return;
    vx_query q;
    memset(&q, 0, sizeof q);
    q.ray_origin = org;
    q.ray_dir = dir;
    q.to_viewer = v3_scale(dir, -1.0f);
    q.voxel_size = g->voxel_size;
    q.effects = j->s->effects;
    while (gt_iter_next(&it, &h)) {
        vec3 hi;
        grid_cell_corners(g, 0, h.x, h.y, h.z, &q.voxel_lo, &hi);
        q.t0 = h.t0;
        q.t1 = h.t1;
        float d = b->len - 0.5f * (h.t0 + h.t1);
        q.footprint = shadow_column_radius(b, d);
        float a = j->m->voxel->opacity.fn(j->records + (size_t)h.index * j->m->record.bytes, &q);
        a = vx_fminf(vx_fmaxf(a, 0.0f), 1.0f);
        if (!(a > 0.0f))
            continue;
        if (!L) {
            f[shadow_slice(b, d)] *= 1.0f - a;
            continue;
        }
        if (L->n == L->cap) {
            size_t cap = L->cap ? 2 * L->cap : 256;
            column_voxel *grown = realloc(L->v, cap * sizeof *grown);
            if (!grown) {
                j->failed = 1;
                return;
            }
            L->v = grown;
            L->cap = cap;
        }
        L->v[L->n++] = (column_voxel){d, a, h.index};
    }
}

/* The model's transmit rule from the light's side over the listed voxels: cum[k] after slice k. */
static void transmit_column(model_job *j, const voxel_list *L, float *cum)
{
    map_build *b = j->b;
    for (int k = 0; k < b->m.slices; k++)
        cum[k] = 2.0f; /* unset */
    float T = 1.0f;
    for (size_t n = L->n; n-- > 0;) {
        const column_voxel *v = &L->v[n];
        float t = j->m->voxel->transmit.fn(j->records + (size_t)v->index * j->m->record.bytes, v->a, T);
        T = vx_fminf(vx_fmaxf(t, 0.0f), T);
        cum[shadow_slice(b, v->d)] = T;
    }
    T = 1.0f;
    for (int k = 0; k < b->m.slices; k++) {
        if (cum[k] <= 1.0f)
            T = vx_fminf(T, cum[k]);
        cum[k] = T;
    }
}

/* The column's transmittance through each slice from the light (cone models): cum[k]. */
static void cone_column(model_job *j, int i, int jj, element_list *L, float *cum)
{
    const voxel_grid *g = j->g;
    map_build *b = j->b;
    vec3 org, dir;
    shadow_column_ray(b, i, jj, 1, &org, &dir);
    cone_ctx x;
    memset(&x, 0, sizeof x);
    x.g = g;
    x.skip = j->skip;
    x.records = j->records;
    x.table = j->table;
    x.effects = j->s->effects;
    x.m = j->m;
    /* A light cone as wide as the column: its radius at the far plane, shrinking toward a point
     * light with the frustum; no narrower than the marcher's light cones (CONE_LIGHT_MIN_RADIUS). */
    float r_far = shadow_column_radius(b, b->len), r_near = shadow_column_radius(b, 0.0f);
    cone c = {org, dir, r_far, (r_near - r_far) / b->len, 0.0f, 1.0f, 1.0f, CONE_LIGHT_MIN_RADIUS * g->voxel_size};
    L->n = 0;
    float t0, t1;
    /* The column's axis inside the grid's box, not its reach (cone_clip_reach, which camera and light
     * cones take): the column's depth records start at its first element, and elements past the
     * bottom face reading a ground there made a lit ground shadow itself (0.12 in test_shadows). */
    if (cone_clip_to_grid(g, org, dir, 0.0f, &t0, &t1)) {
        cone_walk w;
        cone_walk_start(&w, g, dir, vx_fmaxf(t0, 0.0f), vx_fminf(t1, b->len));
        int steps = 0;
        vec3 p;
        float r, tc, level;
        while (cone_next_element(&x, &c, &w, &steps, &p, &r, &tc, &level)) {
            vx_query q;
            cone_element_query(&x, &c, p, r, tc, level, &q);
            vx_answer a;
            memset(&a, 0, sizeof a);
            CONE_ELEMENT(&x, &q, &a);
            w.t = tc + r;
            if (!(a.mask[0] | a.mask[1] | a.mask[2] | a.mask[3]))
                continue;
            if (L->n == L->cap) {
                size_t cap = L->cap ? 2 * L->cap : 256;
                column_element *grown = realloc(L->e, cap * sizeof *grown);
                if (!grown) {
                    j->failed = 1;
                    return;
                }
                L->e = grown;
                L->cap = cap;
            }
            column_element *ce = &L->e[L->n++];
            ce->d = b->len - tc;
            memcpy(ce->mask, a.mask, sizeof ce->mask);
        }
    }
    /* From the light's side (the list runs from the far plane): the union of the masks so far. */
    for (int k = 0; k < b->m.slices; k++)
        cum[k] = 2.0f; /* unset */
    unsigned int covered[VX_MASK_WORDS] = {0, 0, 0, 0};
    for (size_t n = L->n; n-- > 0;) {
        int count = 0;
        for (int wd = 0; wd < VX_MASK_WORDS; wd++) {
            covered[wd] |= L->e[n].mask[wd];
            count += __builtin_popcount(covered[wd]);
        }
        cum[shadow_slice(b, L->e[n].d)] = 1.0f - (float)count / (float)CONE_FULL_MASK;
    }
    float T = 1.0f;
    for (int k = 0; k < b->m.slices; k++) {
        if (cum[k] <= 1.0f)
            T = vx_fminf(T, cum[k]);
        cum[k] = T;
    }
}

static void model_row(void *p, int64_t row, int thread)
{
    model_job *j = p;
    map_build *b = j->b;
    int S = b->m.slices, jj = (int)row;
    float *f = j->scratch + (size_t)thread * 2 * (size_t)S, *cum = f + S;
    for (int i = 0; i < b->m.res; i++) {
        if (j->m->cone) {
            cone_column(j, i, jj, &j->lists[thread], cum);
        } else if (j->m->voxel->transmit.fn) {
            voxel_list *L = &j->vlists[thread];
            L->n = 0;
            voxel_column(j, i, jj, f, L);
            transmit_column(j, L, cum);
        } else {
            for (int k = 0; k < S; k++)
                f[k] = 1.0f;
            voxel_column(j, i, jj, f, NULL);
            float T = 1.0f;
            for (int k = 0; k < S; k++) {
                T *= f[k];
                cum[k] = T;
            }
        }
        shadow_column_finish(b, i, jj, cum);
    }
}

int slicemap_fill_model(const scene *s, const voxel_grid *g, const vx_model *m, const void *records, map_build *b,
                        int threads, vx_err *e)
{
    int n = parallel_threads(threads);
    dilated_grid skip;
    memset(&skip, 0, sizeof skip);
    size_t table_bytes = 0;
    model_job j = {s, g, m, records, m->cone && m->cone->table ? m->cone->table(&table_bytes) : NULL, NULL, b,
                   malloc((size_t)n * 2 * (size_t)b->m.slices * sizeof(float)), calloc((size_t)n, sizeof(element_list)),
                   calloc((size_t)n, sizeof(voxel_list)), 0};
    int rc = 0;
    if (!j.scratch || !j.lists || !j.vlists)
        rc = vx_fail(e, "out of memory for the slicemap-model build");
    else if (m->cone && dilated_build(&skip, g))
        rc = vx_fail(e, "out of memory for the occupancy bitmaps of the slicemap-model build");
    if (!rc) {
        j.skip = m->cone ? &skip : NULL;
        parallel_for(b->m.res, n, model_row, &j, NULL);
        if (j.failed)
            rc = vx_fail(e, "out of memory for the slicemap-model build");
    }
    for (int t = 0; j.lists && t < n; t++)
        free(j.lists[t].e);
    for (int t = 0; j.vlists && t < n; t++)
        free(j.vlists[t].v);
    free(j.vlists);
    free(j.lists);
    free(j.scratch);
    if (m->cone)
        dilated_free(&skip);
    return rc;
}
