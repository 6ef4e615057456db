/* Up-front estimates of what a run needs, computed from the scene, the grid resolution and the
 * image before anything large is allocated: `--dry-run` prints them, and a run whose memory
 * estimate exceeds what the machine can give is refused with it instead of being started and then
 * killed by the kernel. Estimates, not bounds: the grid's size is bounded from the triangles'
 * extents (the exact count needs the voxelisation itself; a .vox file's header has it). */
#ifndef VX_ESTIMATE_H
#define VX_ESTIMATE_H

#include <stdio.h>

#include "error.h"
#include "model.h"
#include "scene.h"
#include "voxfile.h"

typedef struct {
    double scene_bytes;  /* the loaded mesh and Embree's BVH over it */
    double grid_bytes;   /* the voxel grid, with the dense bit array of its build (or a .vox file's cells) */
    double record_bytes; /* the model's records (all MIP levels when it uses them) */
    double work_bytes;   /* per-thread bake samples, the render's shading cache */
    double image_bytes;  /* the float image and its encoding */
    double total_bytes;
    double voxels;       /* estimated non-empty level-0 voxels (0 for truth) */
    double rays;         /* rays to trace (camera, shadow and bake rays) */
    double seconds;      /* at ESTIMATE_RAYS_PER_CORE_SECOND on every thread */
} vx_estimate;

/* Rough tracing rate used for the time estimate (rays per second per core, measured with truth on
 * the 2-core development machine; bake and render rays are of the same order). */
#define ESTIMATE_RAYS_PER_CORE_SECOND 2.0e6
#define ESTIMATE_BAKE_CORE_SECONDS_PER_VOXEL 60e-6

/* truth: image and scene. */
void estimate_truth(const scene *s, int width, int height, int spp, int threads, vx_estimate *out);
/* bake (width = 0: no image) or render: grid at res, records of m, sample rays per voxel. */
void estimate_voxels(const scene *s, const vx_model *m, int res, int rays, int width, int height, int spp,
                     int cache, int threads, vx_estimate *out);
/* render --vox: the voxels and records the file's header gives (exact), its grid rebuilt from the
 * cells it stores (no dense bits, no bake). */
void estimate_vox(const scene *s, const voxfile_header *h, int width, int height, int spp, int cache, int threads,
                  vx_estimate *out);

/* The memory this run may use: the smallest of the machine's available memory (MemAvailable), the
 * address-space limit (ulimit -v) and $VOXLAB_MEMORY_BUDGET (bytes; for shared machines and tests). */
double estimate_budget_bytes(void);
/* Fails, with the estimate and the budget in the message, when est needs more than the budget. */
int estimate_check(const vx_estimate *est, vx_err *e);
/* The estimate as the lines `--dry-run` prints. */
void estimate_print(FILE *f, const char *command, const vx_estimate *est);

#endif
