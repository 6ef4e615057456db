/* The OpenCL backend's cone marching (models with vx_cone_eval): opencl_cone.c. */
#ifndef VX_OPENCL_CONE_H
#define VX_OPENCL_CONE_H

#include "backend.h"
#include "opencl_runtime.h"

/* Renders with model m's cone element on the opened device rt (out allocated by the caller); the
 * build log under build_dir. 0, or -1 with a message. */
int opencl_render_cone(const opencl_runtime *rt, const scene *s, const voxel_grid *g, const vx_model *m,
                       const void *records, const render_options *o, image *out, render_counts *counts,
                       backend_counts *bc, const char *build_dir, vx_err *e);

#endif
