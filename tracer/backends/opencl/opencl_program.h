/* The OpenCL program text for one model: tracer/backends/opencl/cl/prelude.h, the model's cl_source header and
 * tracer/backends/opencl/cl/render.cl, with every quoted #include replaced by the file's text (searched beside the
 * including file, then in tracer/ and models/, as the C build's -I does) and #line markers so that a
 * build log names the real file and line. Assembling one self-contained text, rather than letting
 * the OpenCL compiler follow #include with -I, matters for the kernel cache: PoCL keys its cache on
 * the program text and options, so an edited header must change the text or a stale binary would be
 * reused. The sources are those embedded in the binary at build time (embedded_sources.h), never
 * the files of a source tree, so a built binary always runs the kernels it was built with. */
#ifndef VX_OPENCL_PROGRAM_H
#define VX_OPENCL_PROGRAM_H

#include <stddef.h>

#include "error.h"
#include "model.h"

/* The folder of the running executable (build/ for build/voxlab), where PoCL's kernel cache
 * (pocl-cache/) and the build logs go. */
int opencl_build_dir(char *build_dir, size_t build_size, vx_err *e);

/* The program text for model m (malloc'd, NUL-terminated). params_bytes is sizeof(vx_cl_params) on
 * the host (the program refuses to build when its own differs). Test hook: when the environment
 * sets VOXLAB_OPENCL_BREAK_KERNEL to a non-empty value, a syntax error is appended, so that the
 * build-failure path can be tested (tests/test_opencl.py). */
char *opencl_program_text(const vx_model *m, size_t params_bytes, vx_err *e);

/* A program text from `root` (its #include "..." lines expanded from the source tree the
 * test hook above applied): what opencl_program_text does after writing its root, for kernels
 * assembled elsewhere (tracer/backends/opencl/opencl_cone.c). */
char *opencl_program_expand(const char *root, vx_err *e);

#endif
