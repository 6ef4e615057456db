/* `render --backend opencl`: the device opened, the model handed to its protocol's host
 * (opencl_voxel.c or opencl_cone.c), PoCL's settings. */
#include "opencl_backend.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opencl_cone.h"
#include "opencl_program.h"
#include "opencl_runtime.h"
#include "opencl_voxel.h"

_Static_assert((int)EFFECT_SHADOWS == (int)VX_EFFECT_SHADOWS && (int)EFFECT_DOF == (int)VX_EFFECT_DOF &&
                   (int)EFFECT_SPECULAR == (int)VX_EFFECT_SPECULAR && (int)EFFECT_TEXTURES == (int)VX_EFFECT_TEXTURES,
               "the kernels test scene effects with the VX_EFFECT_* bits");

/* How PoCL's CPU device should run vx_render, set before the first OpenCL call loads PoCL (which
 * reads them then); a PoCL variable the user has set wins. Other platforms ignore them. */
static void pocl_settings(const render_options *o)
{
    /* --threads: PoCL's worker threads, as many as the C backend's. */
    if (o->threads > 0 && !getenv("POCL_CPU_MAX_CU_NUM")) {
        char n[16];
        snprintf(n, sizeof n, "%d", o->threads);
        setenv("POCL_CPU_MAX_CU_NUM", n, 0);
    }
    /* The worker threads sleep between kernels and are woken together by the host thread; the
     * kernel scheduler then tends to start them on the waker's core, where they share it for the
     * first milliseconds of the render (measured: the kernel's wall time exceeded its CPU time / 2
     * by ~8 % on a 2-core machine). Pinned, worker i runs on core i from the start, as the C
     * backend's freshly created threads are spread at once; the tiles (render.cl) still go to
     * whichever thread is free, so a core slowed by another process just takes fewer of them. */
    setenv("POCL_AFFINITY", "1", 0);
    /* The work-group function as a plain loop over the work-items: PoCL's default (loopvec) tries
     * to vectorise across them, which vx_render's persistent, divergent work-items never allow,
     * and its code came out ~2 % slower (CPU time, medians of 11 alternating runs). */
    setenv("POCL_WORK_GROUP_METHOD", "loops", 0);
}

/* Opens the device with PoCL's settings for o and its kernel cache beside the executable. */
static int open_device(opencl_runtime *rt, const render_options *o, char *build_dir, size_t build_size, vx_err *e)
{
    char cache_dir[PATH_MAX + 16];
    if (opencl_build_dir(build_dir, build_size, e))
        return -1;
    snprintf(cache_dir, sizeof cache_dir, "%s/pocl-cache", build_dir);
    pocl_settings(o);
    return opencl_open(rt, cache_dir, e);
}

int opencl_check_available(const vx_model *m, const render_options *o, vx_err *e)
{
    (void)m; /* every registered model has portable evaluation code (model_check) */
    opencl_runtime rt;
    char build_dir[PATH_MAX];
    if (open_device(&rt, o, build_dir, sizeof build_dir, e))
        return -1;
    opencl_close(&rt);
    return 0;
}

int render_image_opencl(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                        const render_options *o, image *out, render_counts *counts, backend_counts *bc, vx_err *e)
{
    memset(bc, 0, sizeof *bc);
    if (o->spp < 1)
        return vx_fail(e, "--spp %d: expected at least 1 ray per pixel", o->spp);
    if ((size_t)o->width * (size_t)o->height > (size_t)INT_MAX / 16 || grid_count(g, 0) > (size_t)INT_MAX / 2)
        return vx_fail(e, "OpenCL backend: %dx%d pixels or %zu voxels is more than it indexes", o->width, o->height,
                       grid_count(g, 0));
    opencl_runtime rt;
    char build_dir[PATH_MAX];
    if (open_device(&rt, o, build_dir, sizeof build_dir, e))
        return -1;
    snprintf(bc->device, sizeof bc->device, "%s", rt.device_name);
    bc->compute_units = rt.compute_units;
    bc->wide_launch = rt.wide;
    int rc = image_alloc(out, o->width, o->height, 3, e);
    if (rc == 0)
        rc = m->cone ? opencl_render_cone(&rt, s, g, m, records, o, out, counts, bc, build_dir, e)
                     : opencl_render_voxels(&rt, s, g, m, records, o, out, counts, bc, build_dir, e);
    opencl_close(&rt);
    if (rc)
        image_free(out);
    return rc;
}
