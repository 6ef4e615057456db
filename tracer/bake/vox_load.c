#include "vox_load.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "parallel.h"
#include "record_check.h"
#include "scene_tris.h"

/* Loads a .vox file for scene s: the model it names, the grid rebuilt from its cells, its records.
 * On failure *records is NULL and nothing is left allocated (see vox_load.h). */
int vox_load(const scene *s, const char *path, const char *model_name, const vx_model **m,
             voxel_grid *g, void **records, voxfile_header *h, double *grid_seconds, vx_err *e)
{
    uint32_t *cells;
    if (voxfile_read(path, s->identity, h, records, &cells, e))
        return -1;
    *m = model_find(h->model);
    int rc = 0;
    if (!*m)
        rc = vx_fail(e, "%s: baked with model \"%s\", which this voxlab does not have", path, h->model);
    else if (model_name && strcmp(model_name, h->model) != 0)
        rc = vx_fail(e, "%s: baked with model \"%s\", not --model %s", path, h->model, model_name);
    else if (h->layout_version != (uint32_t)(*m)->record.layout_version)
        rc = vx_fail(e, "%s: header field layout_version is %u, but model %s reads record layout %d: bake it again",
                     path, h->layout_version, h->model, (*m)->record.layout_version);
    else if (h->n < 1 || h->n > GRID_MAX_N) /* said here, not by grid_build, so that the file is named */
        rc = vx_fail(e, "%s: header field n (grid resolution) is %d, outside 1..%d", path, (int)h->n, GRID_MAX_N);
    if (rc == 0) {
        /* The grid from the file's cells over the scene's lattice (the bake's, as grid_build_scene
         * takes it): the scene identity already ties the file to these triangles. */
        double t0 = now_seconds(), lo[3], hi[3];
        scene_triangle_bounds(s, lo, hi);
        if (grid_build_sorted_cells(g, h->n, lo, hi, cells, (size_t)h->voxels, e)) {
            char why[sizeof e->msg];
            snprintf(why, sizeof why, "%s", e->msg);
            rc = vx_fail(e, "%s: the grid's level-0 cells: %s", path, why);
        }
        *grid_seconds = now_seconds() - t0;
    }
    free(cells);
    if (rc == 0) {
        /* Counted before the grid is freed: the message must say what this grid expects. */
        size_t expected = bake_record_count(*m, g);
        unsigned long long voxels = (unsigned long long)grid_count(g, 0);
        if (h->voxel_bytes != (*m)->record.bytes || h->record_count != expected || h->voxels != voxels) {
            rc = vx_fail(e, "%s: records do not match model %s on this grid (%llu records of %llu bytes for %llu "
                            "voxels, expected %zu of %zu for %llu)",
                         path, h->model, (unsigned long long)h->record_count, (unsigned long long)h->voxel_bytes,
                         (unsigned long long)h->voxels, expected, (*m)->record.bytes, voxels);
            grid_free(g);
        }
    }
    if (rc == 0 && record_check_all(*m, g, *records, (size_t)h->record_count, h->rays, path, e)) {
        grid_free(g);
        rc = -1;
    }
    if (rc) {
        free(*records);
        *records = NULL; /* cmd_render frees it again on every exit */
    }
    return rc;
}
