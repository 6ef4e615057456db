/* A baked .vox file loaded for a scene: header and checksum (voxfile.c), the model it names, the
 * grid rebuilt from the cells it stores (no voxelising), the record count checked against that grid, and every record
 * validated by its model (record_check.c). Shared by `voxlab render --vox` and the .vox fuzzer. */
#ifndef VX_VOX_LOAD_H
#define VX_VOX_LOAD_H

#include "grid.h"
#include "model.h"
#include "scene.h"
#include "voxfile.h"

/* model_name: the --model the user gave (NULL: whatever the file names). On success *m, *g (to be
 * grid_free'd) and *records (to be freed) are the caller's; on failure *records is NULL, no grid is
 * left allocated, and e names the file and the problem. */
int vox_load(const scene *s, const char *path, const char *model_name, const vx_model **m, voxel_grid *g,
             void **records, voxfile_header *h, double *grid_seconds, vx_err *e);

#endif
