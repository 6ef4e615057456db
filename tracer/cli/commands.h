/* The voxlab subcommands (argv[0] is the subcommand's name; each returns the exit status). */
#ifndef VX_COMMANDS_H
#define VX_COMMANDS_H

#include <cjson/cJSON.h>
#include <stdint.h>

#include "bake.h"
#include "scene.h"

int cmd_truth(int argc, char **argv);
int cmd_compare(int argc, char **argv);
int cmd_bake(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_models(int argc, char **argv);

/* --stats JSON helpers: the scene's fields, and writing the object atomically to path. */
cJSON *stats_scene_fields(const scene *s);
/* Writes j to path atomically and frees it. When that fails the command's output file is removed
 * too (a run whose statistics were asked for and lost leaves nothing behind) and -1 returned. */
int stats_finish(cJSON *j, const char *path, const char *cmd, const char *output);
/* The image fields of --stats: spp, width, height, seed, threads, peak_rss_bytes. */
void stats_add_image(cJSON *j, int spp, int width, int height, uint64_t seed, int threads);
/* The bake fields of --stats (model, res, voxels, bytes_per_voxel, bake seconds, ...). */
void stats_add_bake(cJSON *j, const vx_model *m, const voxel_grid *g, const bake_counts *c, int rays,
                    double grid_seconds);
double peak_rss_bytes(void);

/* Builds the grid at resolution res and bakes model m over it (cmd_bake.c). */
int bake_scene(const scene *s, const vx_model *m, int res, const bake_options *o, voxel_grid *g, void **records,
               bake_counts *counts, double *grid_seconds, vx_err *e);

#endif
