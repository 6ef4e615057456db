/* `render --backend opencl`: the voxel tracer of render.c run as OpenCL kernels (tracer/backends/opencl/cl/render.cl)
 * built from the same portable sources as the C backend: the DDA (grid_traverse_core.h), the camera
 * rays (camera.h), the random numbers (rng.h) and the model's own per-voxel evaluation (its
 * cl_source header). Same image as render_image to float rounding of the math library (see
 * tests/test_opencl.py), with the same shading cache (filled by the first ray that visits a voxel).
 *
 * Kernels are compiled once per model and kept by PoCL's cache (POCL_CACHE_DIR, by default
 * pocl-cache/ in the build directory); the compile time is reported apart from the render time.
 * Models that march cones (VX_MARCH_CONE) run in their own kernel (opencl_cone.c, from their
 * cl_cone_element); a model without portable evaluation code is refused with a message. */
#ifndef VX_OPENCL_BACKEND_H
#define VX_OPENCL_BACKEND_H

#include "render.h"

typedef struct {
    double compile_seconds; /* assembling the program, building it (or loading it from the cache), preparing the kernels */
    double kernel_seconds;  /* the render kernel alone (part of render_counts.seconds, with the transfers) */
    double kernel_cpu_seconds; /* CPU time the process spent meanwhile (all threads: PoCL's workers run in it) */
    char device[256];       /* the device's name */
    unsigned compute_units;
} opencl_counts;

/* 0 when model m can run on this backend, else -1 with a message naming the model and why (cone
 * marching, no cl_source): cmd_render asks before baking, so the answer comes at once. */
int opencl_model_check(const vx_model *m, vx_err *e);

/* Like render_image (render.h); counts->seconds is the render without the compile time, and
 * traversal_seconds / model_seconds are not measured (0). */
int render_image_opencl(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                        const render_options *o, image *out, render_counts *counts, opencl_counts *oc, vx_err *e);

#endif
