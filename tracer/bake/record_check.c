#include "record_check.h"

int record_check_all(const vx_model *m, const voxel_grid *g, const void *records, size_t count, int rays,
                     const char *path, vx_err *e)
{
    if (!m->validate_record)
        return 0;
    const unsigned char *rec = records;
    size_t index = 0;
    int levels = m->record.levels ? g->levels : 1;
    for (int level = 0; level < levels; level++) {
        vx_record_context c = {.level = level, .cell_size = (float)(g->voxel_size_d * (double)(1 << level)),
                               .rays = rays};
        size_t n = grid_count(g, level);
        for (size_t i = 0; i < n && index < count; i++, index++) {
            char why[256];
            why[0] = 0; /* not `= ""`: that clears all 256 bytes for every record (0.5 GB at 1024^3) */
            if (m->validate_record(rec + index * m->record.bytes, &c, why, sizeof why) == 0)
                continue;
            int x, y, z;
            grid_coords(g, level, i, &x, &y, &z);
            return vx_fail(e, "%s: voxel %zu (level %d, cell %d,%d,%d): %s record field %s", path, index, level, x, y,
                           z, m->name, why[0] ? why : "?: invalid");
        }
    }
    return 0;
}
