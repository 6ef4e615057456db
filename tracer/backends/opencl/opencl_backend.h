/* The OpenCL backend (backend.h's "opencl"): the marchers of the C backend run as OpenCL kernels
 * (cl/render.cl for voxel evaluation, cl/render_cone.cl for cone evaluation) built from the same
 * portable sources: the marchers' cores (render_voxel_core.h, render_cone_core.h), the DDA, the
 * camera rays, the random numbers and the model's own evaluation. Same image as the C backend to
 * float rounding of the math library (tests/test_opencl.py).
 *
 * Kernels are compiled once per model and kept by PoCL's cache (POCL_CACHE_DIR, by default
 * pocl-cache/ beside the executable); the compile time is reported apart from the render time. */
#ifndef VX_OPENCL_BACKEND_H
#define VX_OPENCL_BACKEND_H

#include "backend.h"

/* 0 when an OpenCL device with double precision opens here (with PoCL's settings for o), else -1
 * with why. */
int opencl_check_available(const vx_model *m, const render_options *o, vx_err *e);

/* backend.h's render; counts->seconds is the render without the compile time, and
 * traversal_seconds / model_seconds are not measured (0). */
int render_image_opencl(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                        const render_options *o, image *out, render_counts *counts, backend_counts *bc, vx_err *e);

#endif
