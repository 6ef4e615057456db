/* The --stats fields of a bake (bake and render): apart from stats.c, which the truth uses too, so
 * that the truth's code path holds none of the bake's. */
#include "bake_params.h"
#include "stats.h"

void stats_add_bake(cJSON *j, const vx_model *m, const struct vx_bake_params *params, const voxel_grid *g,
                    const bake_counts *c, int rays, double grid_seconds)
{
    cJSON_AddStringToObject(j, "model", m->name);
    struct vx_bake_params defaults;
    if (!params) {
        bake_params_defaults(m, &defaults);
        params = &defaults;
    }
    char text[256];
    if (bake_params_format(m, params, text, sizeof text) == 0)
        cJSON_AddStringToObject(j, "model_params", text);
    cJSON_AddNumberToObject(j, "res", g->n);
    cJSON_AddNumberToObject(j, "voxels", (double)grid_count(g, 0));
    cJSON_AddNumberToObject(j, "bytes_per_voxel", (double)m->record.bytes);
    cJSON_AddNumberToObject(j, "records", (double)bake_record_count(m, g));
    cJSON_AddNumberToObject(j, "model_bytes", (double)(bake_record_count(m, g) * m->record.bytes));
    cJSON_AddNumberToObject(j, "grid_bytes", (double)grid_bytes(g));
    cJSON_AddNumberToObject(j, "grid_seconds", grid_seconds);
    if (c->seconds < 0) /* rendered from a .vox file: the bake's time is in that bake's --stats */
        cJSON_AddNullToObject(j, "bake_seconds");
    else
        cJSON_AddNumberToObject(j, "bake_seconds", c->seconds + c->finish_seconds);
    cJSON_AddNumberToObject(j, "bake_rays", (double)c->rays);
    cJSON_AddNumberToObject(j, "rays_per_voxel", rays);
}
