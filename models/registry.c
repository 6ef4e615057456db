/* The registry: the models listed in registry.def (one line each), found by name, and the check of
 * the interface's rules every registered model must keep. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "model.h"

#define VX_MODEL(x) extern const vx_model model_##x;
#include "registry.def"
#undef VX_MODEL

static const vx_model *const models[] = {
#define VX_MODEL(x) &model_##x,
#include "registry.def"
#undef VX_MODEL
    NULL,
};

const vx_model *const *model_all(void) { return models; }

const vx_model *model_find(const char *name)
{
    for (const vx_model *const *m = models; *m; m++)
        if (strcmp((*m)->name, name) == 0)
            return *m;
    return NULL;
}

#define BROKEN(...) (snprintf(why, why_size, __VA_ARGS__), -1)

static int portable_name_ok(const char *name)
{
    if (!name || !*name)
        return 0;
    for (const char *c = name; *c; c++)
        if (!((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') || *c == '_'))
            return 0;
    return 1;
}

int model_check(const vx_model *m, char *why, size_t why_size)
{
    if (m->abi_version != VX_MODEL_ABI_VERSION)
        return BROKEN("abi_version %d, but this voxlab implements model interface version %d", m->abi_version,
                      VX_MODEL_ABI_VERSION);
    if (!m->name || !*m->name || !m->description)
        return BROKEN("a name and a description are required");
    if (m->record.bytes == 0 || m->record.layout_version < 1)
        return BROKEN("record.bytes and record.layout_version (>= 1) are required");
    if (!m->bake_voxel)
        return BROKEN("bake_voxel is required");
    if (!m->voxel == !m->cone)
        return BROKEN("exactly one evaluation protocol (voxel or cone) is required");
    if (m->voxel) {
        const vx_voxel_eval *v = m->voxel;
        if (v->compositing != VX_COMPOSITE_FIRST_HIT && v->compositing != VX_COMPOSITE_ALPHA)
            return BROKEN("voxel evaluation composites first hit or alpha, not rule %d", v->compositing);
        if (!v->source || !v->opacity.fn || !v->shade.fn || !portable_name_ok(v->opacity.name) ||
            !portable_name_ok(v->shade.name))
            return BROKEN("voxel evaluation needs its source and opacity/shade declared with VX_PORTABLE");
        if (v->transmit.fn && !portable_name_ok(v->transmit.name))
            return BROKEN("transmit must be declared with VX_PORTABLE");
        if (v->transmit.fn && v->compositing != VX_COMPOSITE_ALPHA)
            return BROKEN("transmit changes how opacities accumulate: it needs alpha compositing");
        if (v->view_tile_pixels < 0 || v->view_tile_pixels > VX_VIEW_TILE_MAX_PIXELS)
            return BROKEN("view_tile_pixels %d: expected 0 (the exact direction) to %d", v->view_tile_pixels,
                          VX_VIEW_TILE_MAX_PIXELS);
    } else {
        if (!m->cone->source || !m->cone->element.fn || !portable_name_ok(m->cone->element.name))
            return BROKEN("cone evaluation needs its source and element declared with VX_PORTABLE");
        if (!m->record.levels)
            return BROKEN("cone evaluation reads MIP levels: record.levels must be 1");
    }
    if (!m->transform != !m->combine)
        return BROKEN("transform and combine come together (a split record needs combining)");
    if (m->transform && m->record.levels && !m->bake_finish)
        return BROKEN("moved records with levels need bake_finish to rebuild the coarser levels");
    int n = 0;
    for (const vx_param *p = m->params; p && p->name; p++, n++) {
        if (n >= VX_MAX_PARAMS)
            return BROKEN("more than %d parameters", VX_MAX_PARAMS);
        if (!portable_name_ok(p->name) || !p->doc)
            return BROKEN("parameter %d: a name of letters, digits and _ and a doc line are required", n);
        if (!(p->min <= p->fallback && p->fallback <= p->max))
            return BROKEN("parameter %s: default %g outside [%g, %g]", p->name, p->fallback, p->min, p->max);
        if (p->is_switch && !(p->min == 0 && p->max == 1 && (p->fallback == 0 || p->fallback == 1)))
            return BROKEN("parameter %s: a switch needs the range [0, 1] and a default of 0 or 1", p->name);
    }
    return 0;
}
