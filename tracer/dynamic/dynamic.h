/* Moving objects by voxel transformation (the dynamic-SVO paper, §3.1-3.3; issue 17). The static
 * part of an animated scene is baked once, each moving object once on its own at the scene's first
 * frame (same lattice: the grid of the whole animation's bounds); every frame, each object's
 * records are carried into the world lattice by the object's motion since that frame, with the
 * paper's filters:
 *   nearest: a record goes whole to the cell holding its transformed centre;
 *   split8:  a record is split over the 8 cells around its transformed centre, each getting the
 *            fraction of the unit cube centred there that it overlaps (trilinear weights);
 * the record's directional content turned by the motion's rotation (vx_model.transform), and every
 * cell's parts (static records with weight 1 included) merged by vx_model.combine. A scaled
 * object's records cover its scaled footprint: split8 spreads a record over every cell its cube of
 * edge s overlaps, nearest over the cells whose centres it holds (above s = 1), each by the
 * covered volume over s, so that no holes open as the object grows; the records' content is not
 * rescaled (a surface's position within the voxel, heitz-neyret's h, keeps its unscaled length).
 * rebake: the baseline, the scene posed at the frame and baked whole.
 * The parts' records are the whole scene's bake (at the first frame) wherever one part alone touches
 * a voxel; where several do, each part's own bake. */
#ifndef VX_DYNAMIC_H
#define VX_DYNAMIC_H

#include "bake.h"
#include "scene.h"

enum { DYN_REBAKE = 0, DYN_NEAREST = 1, DYN_SPLIT8 = 2 };

/* "rebake", "nearest", "split8" -> DYN_*, -1 for anything else. */
int dyn_filter_from_name(const char *name);
const char *dyn_filter_name(int filter);

typedef struct {
    voxel_grid grid;  /* the part's cells (count 0: an empty part) */
    void *records;
    double A[9], t[3]; /* moving objects: the pose they were baked at */
} dyn_part;

typedef struct {
    const vx_model *m;
    int parts;          /* parts[0]: static; parts[1 + i]: moving object i */
    dyn_part *part;
    int ref_frame;
    struct vx_bake_params params; /* the bake's model parameters (bake_finish rebuilds levels with them) */
    int threads;                  /* the bake's --threads (0: every core): a frame's merge runs on them */
    double bake_seconds; /* baking every part once */
    /* The whole scene baked at the reference frame: a voxel only one part touches takes its record
     * from here, and a frame where nothing moved is this bake, so that the reference frame of every
     * filter is the static render bit for bit. */
    voxel_grid full;
    void *full_records;
} dyn_scene;

typedef struct {
    double transform_seconds; /* positions and records carried into the world lattice, sorted, combined */
    double grid_seconds;      /* the world grid built from the cells */
    size_t parts_in;          /* record parts placed (static records count one each) */
    size_t voxels;            /* world voxels */
    size_t dropped;           /* parts that left the grid */
} dyn_counts;

/* Bakes s's static part and each moving object once (s is posed at its first frame). m must have
 * transform and combine. */
int dyn_prepare(dyn_scene *d, const scene *s, const vx_model *m, int res, const bake_options *o, vx_err *e);
/* The world grid and records at `frame` with filter DYN_NEAREST or DYN_SPLIT8 (records malloc'ed). */
int dyn_frame(const dyn_scene *d, const scene *s, int frame, int filter, voxel_grid *g, void **records, dyn_counts *c,
              vx_err *e);
/* Transforms one object's records (for benchmarks and tests): the records of part p placed at
 * `frame` into the world lattice, as dyn_frame does for that part alone. */
int dyn_frame_parts(const dyn_scene *d, const scene *s, int frame, int filter, const int *parts, int part_count,
                    voxel_grid *g, void **records, dyn_counts *c, vx_err *e);
void dyn_free(dyn_scene *d);
/* The paper's "standard voxelization" of the moving objects alone, as posed now: their grid and
 * bake from scratch (what the transformation replaces), for benchmarks; *seconds its time. */
int dyn_rebake_moving(const scene *s, const vx_model *m, int res, const bake_options *o, double *seconds, vx_err *e);

#endif
