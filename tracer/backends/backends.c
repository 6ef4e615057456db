/* Every render backend voxlab has, one line each (see backend.h). */
#include "backend.h"

#include <string.h>

#include "opencl_backend.h"

static int c_check(const vx_model *m, const render_options *o, vx_err *e)
{
    (void)m, (void)o, (void)e;
    return 0; /* every model's evaluation is portable C */
}

static int c_render(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                    const render_options *o, image *out, render_counts *counts, backend_counts *bc, vx_err *e)
{
    memset(bc, 0, sizeof *bc);
    return render_image(s, g, m, records, o, out, counts, e);
}

static const vx_backend backend_c = {
    .name = "c",
    .description = "the C tracer on the CPU's threads (tracer/render/)",
    .check = c_check,
    .render = c_render,
    .splits_model_time = 1,
};

static const vx_backend backend_opencl = {
    .name = "opencl",
    .description = "the same marchers as OpenCL kernels, on the first OpenCL device with doubles (PoCL here)",
    .check = opencl_check_available,
    .render = render_image_opencl,
    .has_device = 1,
};

static const vx_backend *const backends[] = {&backend_c, &backend_opencl, NULL};

const vx_backend *const *backend_all(void) { return backends; }

const vx_backend *backend_find(const char *name)
{
    for (const vx_backend *const *b = backends; *b; b++)
        if (strcmp((*b)->name, name) == 0)
            return *b;
    return NULL;
}
