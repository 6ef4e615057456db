/* What the hosts of both OpenCL kernels share (opencl_voxel.c: vx_render; opencl_cone.c:
 * vx_render_cone): a launch's program, kernel and buffers and their release; building the model's
 * program; the grid's level tables; persistent-tile launches (work-items taking tiles of pixels
 * from a shared counter until the image is done: on a CPU one work-group per compute unit and tiles
 * of many pixels; launched wide on a GPU, opencl_runtime.h, 16 groups per compute unit taking one
 * pixel at a time, VX_CL_WIDE defined in the program); the per-group
 * counters read back and summed. Each kernel's host keeps only its parameters and buffer list. */
#ifndef VX_OPENCL_HOST_H
#define VX_OPENCL_HOST_H

#include <stdint.h>

#include "backend.h"
#include "grid.h"
#include "model.h"
#include "cl/counters.h"
#include "opencl_runtime.h"

#define OPENCL_HOST_MAX_BUFFERS 16

typedef struct {
    const opencl_runtime *rt;
    cl_program program;
    cl_kernel kernel;
    const char *kernel_name;
    cl_mem buf[OPENCL_HOST_MAX_BUFFERS];
    int buffers;      /* the kernel's buffer arguments, in order; then `int pixels` */
    int next_tile;    /* which buffer is the tile counter */
    size_t local;     /* work-group size */
    size_t groups;    /* one per compute unit, or 16 on a wide launch */
    uint32_t *counts; /* the slots, read back */
    char *source;
} opencl_launch;

/* Assembles the program for model m around `kernel_file` (render.cl or render_cone.cl) with the
 * lines of `defines` first, builds it (or takes it from PoCL's cache; the whole build log goes to
 * build_dir/opencl-build-MODEL.log when long), creates `kernel_name` and sizes the launch: buffers
 * buffer arguments of which next_tile is the tile counter; the kernel keeps cl/counters.h's counters. */
int opencl_launch_build(opencl_launch *L, const opencl_runtime *rt, const vx_model *m, const char *defines,
                        const char *kernel_file, const char *kernel_name, int buffers, int next_tile,
                        const char *build_dir, vx_err *e);
/* Buffer `which` (see opencl_buffer in opencl_runtime.h). */
int opencl_launch_buffer(opencl_launch *L, int which, cl_mem_flags flags, size_t bytes, const void *host, vx_err *e);
/* The counters' buffer `which`, zeroed slots for every group (host memory in L->counts). */
int opencl_launch_counters(opencl_launch *L, int which, vx_err *e);
/* Buffers cols, bits and prefix sized for the grid's level tables, level after level (the offsets
 * vx_cl_grid_params_fill gives); opencl_launch_grid_upload enqueues their contents without waiting
 * (the grid outlives them). */
int opencl_launch_grid(opencl_launch *L, int cols, int bits, int prefix, const voxel_grid *g, vx_err *e);
int opencl_launch_grid_upload(opencl_launch *L, int cols, int bits, int prefix, const voxel_grid *g, vx_err *e);
/* Enqueues filling the first `bytes` (a multiple of 4) of buffer `which` with the 32-bit `word`;
 * opencl_launch_zero with zeros. */
int opencl_launch_fill(opencl_launch *L, int which, size_t bytes, uint32_t word, vx_err *e);
int opencl_launch_zero(opencl_launch *L, int which, size_t bytes, vx_err *e);
/* Resets the tile counter, binds the buffers and `pixels`, runs the kernel and waits. With 0 pixels
 * every work-item finds no tile: PoCL compiles a kernel's work-group function at its first launch,
 * specialised for the local size, so a launch with nothing to do moves that compile out of the
 * render's time. */
int opencl_launch_run(opencl_launch *L, int pixels, const char *what, vx_err *e);
/* Reads image buffer `image_which` into out and the counters back: both reads enqueued, then one
 * wait (each blocking call costs a wake-up of PoCL's threads); counts gets the counters summed over
 * the groups (seconds untouched). */
int opencl_launch_results(opencl_launch *L, int image_which, float *out, size_t image_bytes, int counts_which,
                          render_counts *counts, vx_err *e);
void opencl_launch_release(opencl_launch *L);

/* The moments a render's time is split by (now_seconds), and the CPU time where the render's clock
 * starts (`set_up`). */
typedef struct {
    double start, compiled, bound, warm, set_up, cpu_set_up;
} opencl_clock;

/* The warm-up: a launch with nothing to do (opencl_launch_run with 0 pixels); sets c->warm, and
 * c->set_up and c->cpu_set_up there (nothing left to wait for after it). */
int opencl_launch_warm_up(opencl_launch *L, opencl_clock *c, vx_err *e);

/* Waits for the uploads and clears enqueued after the warm-up (`what` names them in an error) and
 * moves c->set_up and c->cpu_set_up to now: they are the render's set-up, not its frame. */
int opencl_launch_set_up(opencl_launch *L, opencl_clock *c, const char *what, vx_err *e);

/* The timed part of a render, from c->set_up: runs the kernel over `pixels`, reads the image and the
 * counters back into counts, and splits the time as the C backend's: counts->seconds = the run and
 * the read-back; counts->setup_seconds = creating the buffers (bound - compiled) plus the uploads
 * and clears after the warm-up (set_up - warm), as the C backend's set-up (its caches, its maps) is
 * outside its clock; bc->compile_seconds = building (compiled - start) plus the warm-up (warm -
 * bound). */
int opencl_launch_render(opencl_launch *L, const opencl_clock *c, int pixels, const char *what, int image_which,
                         float *out, int counts_which, render_counts *counts, backend_counts *bc, vx_err *e);

#endif
