/* The OpenCL program text for one model: cl/prelude.h, the model's portable source and the kernel
 * (cl/render.cl or cl/render_cone.cl), with every quoted #include replaced by the file's text
 * (searched beside the including file, then in the folders of the C build's -I path) and #line markers so that a
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

/* The program text for model m (malloc'd, NUL-terminated): the lines of `defines` (the kernel's
 * #defines), prelude.h, the model's portable source, then kernel_file (render.cl or
 * render_cone.cl). Test hook: when the environment sets VOXLAB_OPENCL_BREAK_KERNEL to a non-empty
 * value, a syntax error is appended, so that the build-failure path can be tested
 * (tests/test_opencl.py). */
char *opencl_program_text(const vx_model *m, const char *defines, const char *kernel_file, vx_err *e);

#endif
