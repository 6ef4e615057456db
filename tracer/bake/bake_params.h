/* A model's parameters (vx_model.params) from the command line's `--param name=value`: defaults,
 * parsing with clear refusals (an unknown name lists the known ones, as pbrt reports an unused
 * parameter; a value out of range gives the range), and the canonical text a .vox header and
 * --stats record. */
#ifndef VX_BAKE_PARAMS_H
#define VX_BAKE_PARAMS_H

#include <stddef.h>

#include "error.h"
#include "model.h"

/* Every parameter at its default. */
void bake_params_defaults(const vx_model *m, struct vx_bake_params *p);
/* Applies one "name=value" to p (which holds defaults or earlier assignments). */
int bake_params_assign(const vx_model *m, const char *assignment, struct vx_bake_params *p, vx_err *e);
/* Defaults, then each of the n "name=value" assignments in turn. */
int bake_params_apply(const vx_model *m, const char *const *assignments, int n, struct vx_bake_params *p, vx_err *e);
/* "name=value,name=value" in declaration order (%.17g: the values read back exactly); "" for a
 * model without parameters. Returns -1 when it does not fit. */
int bake_params_format(const vx_model *m, const struct vx_bake_params *p, char *out, size_t size);
/* Parses bake_params_format's text back (the .vox header's); -1 with a message when it names
 * another model's parameters or a value out of range. */
int bake_params_parse(const vx_model *m, const char *text, struct vx_bake_params *p, vx_err *e);

#endif
