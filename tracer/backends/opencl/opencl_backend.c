#include "opencl_backend.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "cl/render_params.h"
#include "opencl_cone.h"
#include "opencl_program.h"
#include "opencl_runtime.h"
#include "parallel.h"
#include "strata.h"

_Static_assert((int)EFFECT_SHADOWS == (int)VX_EFFECT_SHADOWS && (int)EFFECT_DOF == (int)VX_EFFECT_DOF &&
                   (int)EFFECT_SPECULAR == (int)VX_EFFECT_SPECULAR && (int)EFFECT_TEXTURES == (int)VX_EFFECT_TEXTURES,
               "the kernels test scene effects with the VX_EFFECT_* bits");

/* Work-group size: a size every device accepts. vx_render's work-items are persistent (they take
 * tiles of pixels from a shared counter until the image is done), and the host launches one group
 * per compute unit: on a CPU device one thread per group, as many as the C backend's threads. */
#define LOCAL_SIZE 64

/* vx_render's arguments, in order (render.cl), then the pixel count. */
enum { B_PARAMS, B_COLS, B_BITS, B_PREFIX, B_RECORDS, B_CACHE, B_STATE, B_IMAGE, B_COUNTS, B_NEXT_TILE, B_N };

typedef struct {
    opencl_runtime rt;
    cl_program program;
    cl_kernel render;
    size_t local; /* work-group size */
    cl_mem buf[B_N];
    char *source;
    uint32_t *counts; /* per work-group counter slots read back */
} cl_state;

static void release(cl_state *st)
{
    for (int i = 0; i < B_N; i++)
        if (st->buf[i])
            clReleaseMemObject(st->buf[i]);
    if (st->render)
        clReleaseKernel(st->render);
    if (st->program)
        clReleaseProgram(st->program);
    opencl_close(&st->rt);
    free(st->source);
    free(st->counts);
}

static int make_buffer(cl_state *st, int which, cl_mem_flags flags, size_t bytes, const void *host, vx_err *e)
{
    st->buf[which] = opencl_buffer(&st->rt, flags, bytes, host, e);
    return st->buf[which] ? 0 : -1;
}

static void fill_params(vx_cl_params *p, const scene *s, const voxel_grid *g, const render_options *o)
{
    memset(p, 0, sizeof *p);
    vx_cl_grid_params_fill(&p->grid, g);
    p->seed = o->seed;
    p->cam = s->camera;
    p->background = s->background;
    p->light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    for (int i = 0; i < p->light_count; i++)
        p->lights[i] = s->lights[i];
    p->spread = camera_pixel_spread(&s->camera, o->height);
    p->stop_opacity = o->stop_opacity;
    p->width = o->width;
    p->height = o->height;
    p->spp = o->spp;
    truth_strata(o->spp, &p->strata_x, &p->strata_y);
    p->effects = s->effects;
    p->shadow_skip = o->shadow_skip;
    p->cache = o->cache;
    p->voxel_count = (int)grid_count(g, 0);
}

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The grid's level tables, concatenated level after level (offsets in vx_cl_params): the buffers. */
static size_t grid_totals(const voxel_grid *g, size_t *words)
{
    size_t cols = 0;
    *words = 0;
    for (int l = 0; l < g->levels; l++) {
        cols += (size_t)g->level[l].n * (size_t)g->level[l].n;
        *words += g->level[l].words;
    }
    return cols;
}

static int make_grid_buffers(cl_state *st, const voxel_grid *g, vx_err *e)
{
    size_t words, cols = grid_totals(g, &words);
    return make_buffer(st, B_COLS, CL_MEM_READ_ONLY, cols * sizeof(uint64_t), NULL, e) ||
                   make_buffer(st, B_BITS, CL_MEM_READ_ONLY, words * sizeof(uint64_t), NULL, e) ||
                   make_buffer(st, B_PREFIX, CL_MEM_READ_ONLY, words * sizeof(uint32_t), NULL, e)
               ? -1
               : 0;
}

/* ... and their contents, enqueued without waiting. */
static int upload_grid(cl_state *st, const voxel_grid *g, vx_err *e)
{
    cl_command_queue q = st->rt.queue;
    size_t c = 0, w = 0;
    for (int l = 0; l < g->levels; l++) {
        const grid_level *L = &g->level[l];
        size_t nc = (size_t)L->n * (size_t)L->n;
        cl_int err = clEnqueueWriteBuffer(q, st->buf[B_COLS], CL_FALSE, c * sizeof(uint64_t), nc * sizeof(uint64_t),
                                          L->cols, 0, NULL, NULL);
        if (err == CL_SUCCESS && L->words) {
            err = clEnqueueWriteBuffer(q, st->buf[B_BITS], CL_FALSE, w * sizeof(uint64_t), L->words * sizeof(uint64_t),
                                       L->bits, 0, NULL, NULL);
            if (err == CL_SUCCESS)
                err = clEnqueueWriteBuffer(q, st->buf[B_PREFIX], CL_FALSE, w * sizeof(uint32_t),
                                           L->words * sizeof(uint32_t), L->prefix, 0, NULL, NULL);
        }
        if (opencl_check(err, "uploading the grid", e))
            return -1;
        c += nc;
        w += L->words;
    }
    return 0;
}

/* Runs kernel k as `groups` work-groups of `local` work-items and waits for it. */
static int run(cl_state *st, cl_kernel k, size_t local, size_t groups, const char *what, vx_err *e)
{
    size_t global = groups * local;
    cl_int err = clEnqueueNDRangeKernel(st->rt.queue, k, 1, NULL, &global, &local, 0, NULL, NULL);
    if (err == CL_SUCCESS)
        err = clFinish(st->rt.queue);
    return opencl_check(err, what, e);
}

static size_t local_size(const cl_state *st, cl_kernel k)
{
    size_t local = LOCAL_SIZE, max = 0;
    if (clGetKernelWorkGroupInfo(k, st->rt.device, CL_KERNEL_WORK_GROUP_SIZE, sizeof max, &max, NULL) == CL_SUCCESS &&
        max > 0 && max < local)
        local = max;
    return local;
}

/* The program for model m, built (or taken from PoCL's cache), and its two kernels. */
static int compile(cl_state *st, const vx_model *m, const char *build_dir, vx_err *e)
{
    st->source = opencl_program_text(m, sizeof(vx_cl_params), e);
    if (!st->source)
        return -1;
    char what[128], log_path[PATH_MAX + 64];
    snprintf(what, sizeof what, "model %s", m->name);
    snprintf(log_path, sizeof log_path, "%s/opencl-build-%s.log", build_dir, m->name);
    if (opencl_build(&st->rt, st->source, what, log_path, &st->program, e))
        return -1;
    cl_int err;
    st->render = clCreateKernel(st->program, "vx_render", &err);
    if (!st->render)
        return opencl_check(err, "creating kernel vx_render", e);
    st->local = local_size(st, st->render);
    return 0;
}

static int bind(cl_state *st, int pixels, vx_err *e)
{
    cl_int err = CL_SUCCESS;
    for (int i = 0; i < B_N && err == CL_SUCCESS; i++)
        err = clSetKernelArg(st->render, (cl_uint)i, sizeof(cl_mem), &st->buf[i]);
    if (err == CL_SUCCESS)
        err = clSetKernelArg(st->render, B_N, sizeof(int), &pixels);
    return opencl_check(err, "setting the arguments of vx_render", e);
}

/* Sets the tile counter to 0 before a launch: vx_render's work-items start from the first tile. */
static int reset_tiles(cl_state *st, vx_err *e)
{
    cl_int zero = 0;
    return opencl_check(clEnqueueFillBuffer(st->rt.queue, st->buf[B_NEXT_TILE], &zero, sizeof zero, 0, sizeof zero, 0,
                                        NULL, NULL),
                    "resetting the tile counter", e);
}

/* Launches the kernel once over the real size with nothing to do (0 pixels: every work-item finds
 * no tile). PoCL compiles a kernel's work-group function at its first launch, specialised for the
 * local size and for whether the grid is small, so the real size is needed; that compile belongs
 * to the compile time, not to the render. */
static int warm_up(cl_state *st, size_t groups, vx_err *e)
{
    return reset_tiles(st, e) || bind(st, 0, e) || run(st, st->render, st->local, groups, "preparing vx_render", e)
               ? -1
               : 0;
}

/* Sums the per-work-group counter slots (cl_flush_counts) of `groups` groups into sums. */
static void add_counts(const uint32_t *slots, size_t groups, uint64_t sums[VX_CL_COUNTERS])
{
    for (size_t gi = 0; gi < groups; gi++)
        for (int k = 0; k < VX_CL_COUNTERS; k++) {
            const uint32_t *w = &slots[(gi * VX_CL_COUNTERS + (size_t)k) * 2];
            sums[k] += (uint64_t)w[0] | (uint64_t)w[1] << 32;
        }
}

/* Reads the image and the counters back in one round trip: both reads enqueued, then one wait (each
 * blocking call costs a wake-up of PoCL's threads, ~0.1 ms, ~1 % of a small render). The image
 * buffer uses out->data as its memory (CL_MEM_USE_HOST_PTR), so on a CPU device its read is a copy
 * onto itself or nothing; the spec allows it here, the kernel having finished and nothing else
 * using the buffer. */
static int read_results(cl_state *st, image *out, size_t image_bytes, size_t count_bytes, vx_err *e)
{
    cl_command_queue q = st->rt.queue;
    cl_int err = clEnqueueReadBuffer(q, st->buf[B_IMAGE], CL_FALSE, 0, image_bytes, out->data, 0, NULL, NULL);
    if (err == CL_SUCCESS)
        err = clEnqueueReadBuffer(q, st->buf[B_COUNTS], CL_FALSE, 0, count_bytes, st->counts, 0, NULL, NULL);
    if (err == CL_SUCCESS)
        err = clFinish(q);
    return opencl_check(err, "reading the image and the counters back", e);
}

static int render_on_device(cl_state *st, const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                            const render_options *o, image *out, render_counts *counts, opencl_counts *oc,
                            const char *build_dir, vx_err *e)
{
    size_t voxels = grid_count(g, 0), pixels = (size_t)o->width * (size_t)o->height;
    double t0 = now_seconds();
    if (compile(st, m, build_dir, e))
        return -1;
    double t_compiled = now_seconds();
    size_t groups = st->rt.compute_units ? st->rt.compute_units : 1;
    size_t slot_bytes = 2 * VX_CL_COUNTERS * sizeof(uint32_t);
    st->counts = calloc(groups, slot_bytes);
    if (!st->counts)
        return vx_fail(e, "out of memory for the render's counters");
    vx_cl_params params;
    fill_params(&params, s, g, o);
    size_t cached = o->cache ? voxels : 0;
    const cl_mem_flags RO = CL_MEM_READ_ONLY, RW = CL_MEM_READ_WRITE;
    /* The kernel only reads the records and only writes the image: both used in place. */
    if (make_buffer(st, B_PARAMS, RO, sizeof params, &params, e) || make_grid_buffers(st, g, e) ||
        make_buffer(st, B_RECORDS, RO | CL_MEM_USE_HOST_PTR, voxels * m->voxel_bytes, records, e) ||
        make_buffer(st, B_CACHE, RW, cached * sizeof(vx_cl_cache), NULL, e) ||
        make_buffer(st, B_STATE, RW, cached * sizeof(cl_int), NULL, e) ||
        make_buffer(st, B_IMAGE, CL_MEM_WRITE_ONLY | CL_MEM_USE_HOST_PTR, pixels * 3 * sizeof(float), out->data, e) ||
        make_buffer(st, B_COUNTS, RW, groups * slot_bytes, st->counts, e) ||
        make_buffer(st, B_NEXT_TILE, RW, sizeof(cl_int), NULL, e))
        return -1;
    double t_bound = now_seconds();
    /* The warm-up reads none of the grid, the cache or the image: it runs on the empty buffers. */
    if (warm_up(st, groups, e))
        return -1;
    double t_warm = now_seconds(), cpu_warm = cpu_seconds();
    /* The uploads, the clearing of the cache and the render, enqueued together: one wait, inside the
     * render's time (each wait costs a wake-up of PoCL's threads). */
    cl_int zero = 0, err = CL_SUCCESS;
    if (cached)
        err = clEnqueueFillBuffer(st->rt.queue, st->buf[B_STATE], &zero, sizeof zero, 0, cached * sizeof(cl_int), 0,
                                  NULL, NULL);
    if (opencl_check(err, "clearing the shading cache", e) || upload_grid(st, g, e) || reset_tiles(st, e) ||
        bind(st, (int)pixels, e) || run(st, st->render, st->local, groups, "running vx_render", e))
        return -1;
    double t_traced = now_seconds();
    oc->kernel_cpu_seconds = cpu_seconds() - cpu_warm;
    if (read_results(st, out, pixels * 3 * sizeof(float), groups * slot_bytes, e))
        return -1;
    double t_done = now_seconds();

    uint64_t sums[VX_CL_COUNTERS] = {0};
    add_counts(st->counts, groups, sums);
    memset(counts, 0, sizeof *counts);
    counts->rays = (uint64_t)pixels * (uint64_t)o->spp;
    counts->voxel_visits = sums[VX_CL_VISITS];
    counts->shadow_rays = sums[VX_CL_SHADOW_RAYS];
    counts->model_evals = sums[VX_CL_EVALS];
    counts->cache_hits = o->cache ? sums[VX_CL_VISITS] - sums[VX_CL_EVALS] : 0;
    oc->compile_seconds = (t_compiled - t0) + (t_warm - t_bound);
    oc->kernel_seconds = t_traced - t_warm;
    counts->seconds = (t_bound - t_compiled) + (t_done - t_warm);
    return 0;
}

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

int opencl_model_check(const vx_model *m, vx_err *e)
{
    if (m->march == VX_MARCH_CONE) {
        /* Cone marching runs in its own kernel (opencl_cone.c), from the model's cone element. */
        if (!m->cl_source || !m->cl_cone_element)
            return vx_fail(e, "model %s cannot run on OpenCL: it marches cones (VX_MARCH_CONE) without a portable "
                              "cone element (cl_source, cl_cone_element in models/model.h); use --backend c",
                           m->name);
        return 0;
    }
    if (!m->cl_source || !m->cl_opacity || !m->cl_shade)
        return vx_fail(e, "model %s cannot run on OpenCL: it declares no portable evaluation source (cl_source, "
                          "cl_opacity, cl_shade in models/model.h); use --backend c",
                       m->name);
    return 0;
}

int render_image_opencl(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                        const render_options *o, image *out, render_counts *counts, opencl_counts *oc, vx_err *e)
{
    memset(oc, 0, sizeof *oc);
    if (o->spp < 1)
        return vx_fail(e, "--spp %d: expected at least 1 ray per pixel", o->spp);
    if (opencl_model_check(m, e))
        return -1;
    if ((size_t)o->width * (size_t)o->height > (size_t)INT_MAX / VX_CL_COUNTERS || grid_count(g, 0) > (size_t)INT_MAX / 2)
        return vx_fail(e, "OpenCL backend: %dx%d pixels or %zu voxels is more than it indexes", o->width, o->height,
                       grid_count(g, 0));
    char build_dir[PATH_MAX], cache_dir[PATH_MAX + 16];
    if (opencl_build_dir(build_dir, sizeof build_dir, e))
        return -1;
    snprintf(cache_dir, sizeof cache_dir, "%s/pocl-cache", build_dir);
    pocl_settings(o);
    cl_state st;
    memset(&st, 0, sizeof st);
    if (opencl_open(&st.rt, cache_dir, e))
        return -1;
    snprintf(oc->device, sizeof oc->device, "%s", st.rt.device_name);
    oc->compute_units = st.rt.compute_units;
    if (image_alloc(out, o->width, o->height, 3, e)) {
        release(&st);
        return -1;
    }
    int rc = m->march == VX_MARCH_CONE
                 ? opencl_render_cone(&st.rt, s, g, m, records, o, out, counts, oc, build_dir, e)
                 : render_on_device(&st, s, g, m, records, o, out, counts, oc, build_dir, e);
    release(&st);
    if (rc)
        image_free(out);
    return rc;
}
