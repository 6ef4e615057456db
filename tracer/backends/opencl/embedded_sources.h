/* The OpenCL kernels' sources, embedded in the binary at build time (embed_sources.sh writes the
 * table into the build folder): the program assembler (opencl_program.c) reads them from here, never
 * from the source tree, so a binary always renders with the kernels it was built with. */
#ifndef VX_EMBEDDED_SOURCES_H
#define VX_EMBEDDED_SOURCES_H

#include <stddef.h>

typedef struct {
    const char *path; /* relative to the repository root, e.g. "tracer/backends/opencl/cl/render.cl" */
    const char *text; /* NUL-terminated */
    size_t size;
} vx_embedded_source;

/* Every .h and .cl file of the tracer and model folders; ends with a {0} entry. */
extern const vx_embedded_source vx_embedded_sources[];
/* The #include search path (the C build's -I folders, in order); ends with NULL. */
extern const char *const vx_source_dirs[];

#endif
