/* Validation of the records of a .vox file against the model that baked them (vx_model's
 * validate_record): the tracer stays model-agnostic, the model says what its record may hold. */
#ifndef VX_RECORD_CHECK_H
#define VX_RECORD_CHECK_H

#include <stddef.h>

#include "error.h"
#include "grid.h"
#include "model.h"

/* Checks each of `count` records (count = bake_record_count(m, g)) with m->validate_record (a
 * model without one passes). Fails on the first bad record with a message naming `path`, the
 * record's voxel index, level and cell, and the field. */
int record_check_all(const vx_model *m, const voxel_grid *g, const void *records, size_t count, int rays,
                     const char *path, vx_err *e);

#endif
