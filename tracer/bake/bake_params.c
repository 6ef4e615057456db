#include "bake_params.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void bake_params_defaults(const vx_model *m, struct vx_bake_params *p)
{
    memset(p, 0, sizeof *p);
    int i = 0;
    for (const vx_param *d = m->params; d && d->name && i < VX_MAX_PARAMS; d++, i++)
        p->value[i] = d->fallback;
}

static void known_names(const vx_model *m, char *out, size_t size)
{
    out[0] = 0;
    size_t len = 0;
    for (const vx_param *d = m->params; d && d->name; d++) {
        int n = snprintf(out + len, size - len, "%s%s", len ? ", " : "", d->name);
        if (n < 0 || (size_t)n >= size - len)
            break;
        len += (size_t)n;
    }
    if (!len)
        snprintf(out, size, "none");
}

int bake_params_assign(const vx_model *m, const char *assignment, struct vx_bake_params *p, vx_err *e)
{
    const char *eq = strchr(assignment, '=');
    if (!eq || eq == assignment)
        return vx_fail(e, "--param %s: expected name=value", assignment);
    size_t name_len = (size_t)(eq - assignment);
    int i = 0;
    for (const vx_param *d = m->params; d && d->name; d++, i++) {
        if (strlen(d->name) != name_len || strncmp(d->name, assignment, name_len) != 0)
            continue;
        char *end;
        errno = 0;
        double v = strtod(eq + 1, &end);
        if (end == eq + 1 || *end || errno || !isfinite(v))
            return vx_fail(e, "--param %s: the value of %s must be a number", assignment, d->name);
        if (d->is_switch && v != 0 && v != 1)
            return vx_fail(e, "--param %s: %s is a switch: expected 0 or 1 (default %g: %s)", assignment, d->name,
                           d->fallback, d->doc);
        if (!(v >= d->min && v <= d->max))
            return vx_fail(e, "--param %s: %s must be in [%g, %g] (default %g: %s)", assignment, d->name, d->min,
                           d->max, d->fallback, d->doc);
        p->value[i] = v;
        return 0;
    }
    char names[512];
    known_names(m, names, sizeof names);
    return vx_fail(e, "--param %s: model %s has no parameter \"%.*s\" (its parameters: %s)", assignment, m->name,
                   (int)name_len, assignment, names);
}

int bake_params_apply(const vx_model *m, const char *const *assignments, int n, struct vx_bake_params *p, vx_err *e)
{
    bake_params_defaults(m, p);
    for (int i = 0; i < n; i++)
        if (bake_params_assign(m, assignments[i], p, e))
            return -1;
    return 0;
}

int bake_params_format(const vx_model *m, const struct vx_bake_params *p, char *out, size_t size)
{
    size_t len = 0;
    out[0] = 0;
    int i = 0;
    for (const vx_param *d = m->params; d && d->name; d++, i++) {
        int n = snprintf(out + len, size - len, "%s%s=%.17g", len ? "," : "", d->name, p->value[i]);
        if (n < 0 || (size_t)n >= size - len)
            return -1;
        len += (size_t)n;
    }
    return 0;
}

int bake_params_parse(const vx_model *m, const char *text, struct vx_bake_params *p, vx_err *e)
{
    bake_params_defaults(m, p);
    char buf[1024];
    if (strlen(text) >= sizeof buf)
        return vx_fail(e, "model parameters \"%.40s...\": too long", text);
    snprintf(buf, sizeof buf, "%s", text);
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok; tok = strtok_r(NULL, ",", &save))
        if (bake_params_assign(m, tok, p, e))
            return -1;
    return 0;
}
