/* Internals shared by the C tracer's files: render.c (the driver: options, threads, rows, counts),
 * render_voxel.c (voxel marching, render_voxel_core.h) and render_cone.c (cone marching,
 * render_cone_core.h). Each marcher knows only the job; neither knows the other. */
#ifndef VX_RENDER_INTERNAL_H
#define VX_RENDER_INTERNAL_H

#include "cycles.h"
#include "parallel.h"
#include "render.h"

/* The model's share of a frame (render_counts.model_seconds) is measured on every
 * RENDER_TIMED_ROW_STRIDE-th image row (rows 0, 8, 16, ...): the model's calls in those rows and
 * those rows' whole time, each read with the time-stamp counter, and their ratio scales the frame.
 * Why not every row: two counter reads per model call (about 11 ns each on these machines) were
 * 2.5-4 % of a frame (alpha and vicini on bunny and city, heitz-neyret's elements), time that the
 * frame's `seconds` counted as the model's or the tracer's own. */
#define RENDER_TIMED_ROW_STRIDE 8

static inline int render_row_timed(int64_t row) { return row % RENDER_TIMED_ROW_STRIDE == 0; }

/* One call of the model's, `call` (a statement), run in context x (x->timed: this row is timed;
 * x->model_cycles: where its time goes), clocked only in a timed row. A macro rather than a
 * start/stop pair of functions: the untimed call then costs one branch, as if written out (the pair
 * tested x->timed again after the call: +0.6 to 1 % on five of six frames measured). */
#define MODEL_CALL(x, call)                                \
    do {                                                   \
        if (!(x)->timed) {                                 \
            call;                                          \
        } else {                                           \
            uint64_t model_call_c0 = cycles();             \
            call;                                          \
            (x)->model_cycles += cycles() - model_call_c0; \
        }                                                  \
    } while (0)

/* One thread's counters, on its own cache line: model_cycles and total_cycles over the timed rows
 * only. */
typedef struct {
    uint64_t rays, shadow_rays, voxel_visits, model_evals, cache_hits, model_cycles, total_cycles;
    uint64_t shadow_queries, memo_hits;
    char pad[64];
} thread_counts;

typedef struct render_job {
    const scene *s;
    const voxel_grid *g;
    const vx_model *m;
    const unsigned char *records;
    const render_options *o;
    image *out;
    thread_counts *tc;
    float spread; /* footprint radius per unit distance */
    void *state;  /* the marcher's own (its caches) */
    const shadow_set *shadows; /* precomputed shadow maps, or NULL: shadows are marched */
    size_t cache_bytes;        /* the marcher's caches, set by prepare (render_counts.cache_bytes) */
    size_t map_bytes;          /* its maps, set by prepare (render_counts.map_bytes) */
    int shadow_method;         /* the shadow method in effect (SHADOW_*; -1: no shadows) */
    double shadow_build_seconds; /* the `voxel` method's precomputation, set by prepare (render_counts.shadows) */
    size_t shadow_bytes;         /* and its memory */
} render_job;

/* A way of marching the pixels of a model's protocol. prepare allocates the marcher's state before
 * the render's clock starts; begin (optional) does the frame's own set-up, inside the clock, with
 * `threads` threads (what depends on the camera); row renders one image row on thread `thread`
 * (parallel_for). */
typedef struct {
    int (*prepare)(render_job *j, vx_err *e);
    void (*begin)(render_job *j, int threads);
    void (*row)(void *job, int64_t row, int thread);
    void (*release)(render_job *j);
} render_marcher;

extern const render_marcher render_voxel_marcher; /* render_voxel.c: vx_voxel_eval models */
extern const render_marcher render_cone_marcher;  /* render_cone.c: vx_cone_eval models */

#endif
