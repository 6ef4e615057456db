/* The render backends: a table of ways to run the same render (the C tracer, OpenCL kernels), each
 * with a name, an availability check and a render entry point. `render --backend NAME` picks one;
 * nothing else in the tracer names a backend. ARCHITECTURE.md says how to add one. */
#ifndef VX_BACKEND_H
#define VX_BACKEND_H

#include "render.h"

/* What a backend measures beyond render_counts (0 / "" where it has no such thing). */
typedef struct {
    double compile_seconds;    /* building the kernels (or loading them from a cache), apart from the render */
    double kernel_seconds;     /* the render kernel alone (part of render_counts.seconds, with the transfers) */
    double kernel_cpu_seconds; /* CPU time the process spent meanwhile (all threads) */
    char device[256];          /* the device's name */
    unsigned compute_units;
    int wide_launch; /* launched as for a GPU: many work-items, one pixel at a time (opencl_host.h) */
} backend_counts;

typedef struct vx_backend {
    const char *name;        /* "c", "opencl" */
    const char *description; /* one line */
    /* 0 when this backend can render model m on this machine, else -1 with why (asked before any
     * bake, so that the answer comes at once). */
    int (*check)(const vx_model *m, const render_options *o, vx_err *e);
    /* Like render_image (render.h); bc gets the backend's own figures. */
    int (*render)(const scene *s, const voxel_grid *g, const vx_model *m, const void *records, const render_options *o,
                  image *out, render_counts *counts, backend_counts *bc, vx_err *e);
    /* 1 when render_counts' traversal_seconds / model_seconds are measured (else reported as null). */
    int splits_model_time;
    /* 1 when backend_counts' fields are measured (--stats writes them as NAME_compile_seconds ...). */
    int has_device;
} vx_backend;

/* The table (tracer/backends/backends.c). */
const vx_backend *backend_find(const char *name);
const vx_backend *const *backend_all(void); /* NULL-terminated */

#endif
