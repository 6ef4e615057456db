/* The OpenCL backend's voxel marching (models with vx_voxel_eval): opencl_voxel.c. */
#ifndef VX_OPENCL_VOXEL_H
#define VX_OPENCL_VOXEL_H

#include "backend.h"
#include "opencl_runtime.h"

/* Renders with model m's voxel evaluation on the opened device rt (out allocated by the caller);
 * the build log under build_dir. 0, or -1 with a message. */
int opencl_render_voxels(const opencl_runtime *rt, const scene *s, const voxel_grid *g, const vx_model *m,
                         const void *records, const render_options *o, image *out, render_counts *counts,
                         backend_counts *bc, const char *build_dir, vx_err *e);

#endif
