/* --stats JSON helpers shared by the commands (tracer/cli/stats.c). */
#ifndef VX_STATS_H
#define VX_STATS_H

#include <cjson/cJSON.h>
#include <stdint.h>

#include "backend.h"
#include "image_meta.h"
#include "bake.h"
#include "scene.h"
#include "truth.h"

/* The scene's fields: name, triangles, effects. */
cJSON *stats_scene_fields(const scene *s);
/* Writes j to path atomically and frees it. When that fails the command's output file is removed
 * too (a run whose statistics were asked for and lost leaves nothing behind) and -1 returned. */
int stats_finish(cJSON *j, const char *path, const char *cmd, const char *output);
/* The image fields of --stats: spp, width, height, seed, threads, peak_rss_bytes. */
void stats_add_image(cJSON *j, int spp, int width, int height, uint64_t seed, int threads);
/* The bake fields of --stats (model, its parameters, res, voxels, bytes_per_voxel, bake seconds,
 * ...); params NULL: the model's defaults. */
void stats_add_bake(cJSON *j, const vx_model *m, const struct vx_bake_params *params, const voxel_grid *g,
                    const bake_counts *c, int rays, double grid_seconds);
/* A device backend's figures as NAME_compile_seconds, NAME_kernel_seconds, NAME_kernel_cpu_seconds,
 * NAME_device, NAME_compute_units, NAME_wide_launch. */
void stats_add_backend(cJSON *j, const char *name, const backend_counts *bc);
/* The shadow method's fields: shadow_method (null when the scene declares no shadows), shadow_res,
 * shadow_build_seconds (the precomputation, apart from seconds; 0 from the cache), shadow_bytes,
 * shadow_queries, shadow_cache_hit. */
void stats_add_shadows(cJSON *j, const shadow_stats *st);
double peak_rss_bytes(void);

/* The provenance every image a command writes carries (EXR header attributes): the build, the
 * command line, the scene (name, identity hash), size, spp, seed. */
void provenance_common(image_meta *m, int argc, char **argv, const scene *s, int width, int height, int spp,
                       uint64_t seed);

/* Each command's whole --stats object (the Python API, tracer/api/, returns the same as a dict). */
cJSON *stats_truth(const scene *s, const truth_options *o, const truth_counts *c);
cJSON *stats_bake(const scene *s, const vx_model *m, const bake_options *o, const voxel_grid *g, const bake_counts *c,
                  double grid_seconds);
cJSON *stats_render(const scene *s, const vx_model *m, const bake_options *bo, const voxel_grid *g,
                    const bake_counts *bc, double grid_seconds, const vx_backend *b, const render_options *o,
                    const render_counts *rc, const backend_counts *bcnt);

#endif
