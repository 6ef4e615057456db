/* Building a shadow_set: every light's map (its frame: shadow_frame.c), filled by a builder
 * (slicemap_triangles.c, or the slicemap-model builder the renderer hands in), and the maps packed
 * into one block with the per-word ranks the query's popcount indexes (shadow_maps_core.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "parallel.h"
#include "shadow_build_internal.h"

/* Packs the maps into set's block (bits | prefix | T | opaque) and sets their offsets. */
static int pack(map_build *b, int count, shadow_set *set, vx_err *e)
{
    size_t words = 0, values = 0, columns = 0;
    for (int li = 0; li < count; li++) {
        size_t cols = (size_t)b[li].m.res * (size_t)b[li].m.res;
        words += cols * (size_t)b[li].m.words;
        for (int j = 0; j < b[li].m.res; j++)
            values += b[li].row_n[j];
        columns += b[li].m.has_opaque ? cols : 0;
    }
    set->words = words, set->values = values, set->columns = columns;
    set->prefix_at = words * sizeof(uint64_t);
    set->T_at = set->prefix_at + words * sizeof(uint32_t);
    set->opaque_at = set->T_at + values * sizeof(float);
    set->bytes = set->opaque_at + columns * sizeof(float);
    set->block = malloc(set->bytes ? set->bytes : 1);
    if (!set->block)
        return vx_fail(e, "out of memory for the shadow maps (%zu bytes)", set->bytes);
    uint64_t *bits = (uint64_t *)set->block;
    uint32_t *prefix = (uint32_t *)(set->block + set->prefix_at);
    float *T = (float *)(set->block + set->T_at), *opaque = (float *)(set->block + set->opaque_at);
    size_t wo = 0, to = 0, oo = 0;
    for (int li = 0; li < count; li++) {
        shadow_map_params *m = &b[li].m;
        size_t cols = (size_t)m->res * (size_t)m->res, n = cols * (size_t)m->words;
        m->bits_off = wo, m->T_off = to, m->opaque_off = oo;
        memcpy(bits + wo, b[li].bits, n * sizeof *bits);
        uint32_t rank = 0;
        for (size_t k = 0; k < n; k++) {
            prefix[wo + k] = rank;
            rank += (uint32_t)__builtin_popcountll(bits[wo + k]);
        }
        for (int j = 0; j < m->res; j++) {
            if (b[li].row_n[j]) /* an empty row has no array: memcpy from NULL is undefined even for 0 bytes */
                memcpy(T + to, b[li].row_T[j], b[li].row_n[j] * sizeof *T);
            to += b[li].row_n[j];
        }
        if (to - m->T_off != rank)
            return vx_fail(e, "shadow map of light %d: %u bits but %zu values (a builder's bug)", li, rank,
                           to - (size_t)m->T_off);
        if (m->has_opaque) {
            memcpy(opaque + oo, b[li].opaque, cols * sizeof *opaque);
            oo += cols;
        }
        wo += n;
        set->params.map[li] = *m;
    }
    return 0;
}

int shadow_set_build(const scene *s, const voxel_grid *g, const vx_model *m, const void *records, int method,
                     int res, int threads, shadow_model_filler fill_model, shadow_set *out, vx_err *e)
{
    memset(out, 0, sizeof *out);
    double t0 = now_seconds();
    int count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    map_build b[VX_MAX_LIGHTS];
    memset(b, 0, sizeof b);
    int rc = 0;
    for (int li = 0; li < count && !rc; li++) {
        rc = shadow_frame(s, &s->lights[li], li, res, method == SHADOW_SLICEMAP, &b[li], e);
        if (!rc)
            rc = method == SHADOW_SLICEMAP ? slicemap_fill_triangles(s, &b[li], threads, e)
                                           : fill_model(s, g, m, records, &b[li], threads, e);
        if (!rc && b[li].failed)
            rc = vx_fail(e, "out of memory for the shadow map of light %d", li);
    }
    out->params.method = method;
    out->params.count = count;
    if (!rc)
        rc = pack(b, count, out, e);
    for (int li = 0; li < count; li++)
        map_build_free(&b[li]);
    if (rc) {
        shadow_set_free(out);
        return -1;
    }
    out->build_seconds = now_seconds() - t0;
    return 0;
}

void shadow_set_free(shadow_set *set)
{
    free(set->block);
    memset(set, 0, sizeof *set);
}

void shadow_set_view(const shadow_set *set, shadow_maps *out)
{
    memset(out, 0, sizeof *out);
    if (!set)
        return;
    out->p = &set->params;
    out->bits = (const uint64_t *)set->block;
    out->prefix = (const uint32_t *)(set->block + set->prefix_at);
    out->T = (const float *)(set->block + set->T_at);
    out->opaque = (const float *)(set->block + set->opaque_at);
}
