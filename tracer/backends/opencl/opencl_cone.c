/* The OpenCL backend for cone-marching models (VX_MARCH_CONE): builds the program from the model's
 * cl_source and tracer/backends/opencl/cl/render_cone.cl (which runs tracer/render/render_cone_core.h, the C backend's
 * marcher), uploads the grid, the records of every level, the model's table, the dilated
 * occupancy bitmaps and an empty light cache, and runs vx_render_cone, one work-group per compute
 * unit whose work-items take tiles of pixels from a shared counter.
 * opencl_backend.c opens the device and hands cone models here. */
#include "opencl_cone.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "cl/render_cone_params.h"
#include "cone_light_cache.h"
#include "cone_skip.h"
#include "opencl_program.h"
#include "parallel.h"

/* Work-group size: a size every device accepts. vx_render_cone's work-items are persistent (they
 * take tiles of pixels from a shared counter until the image is done) and the host launches one
 * group per compute unit: on a CPU device one thread per group, as many as the C backend's. */
#define CONE_LOCAL_SIZE 64

/* vx_render_cone's buffer arguments, in order (render_cone.cl), then the pixel count. */
enum { C_PARAMS, C_COLS, C_BITS, C_PREFIX, C_RECORDS, C_TABLE, C_DILATED, C_LC_KEYS, C_LC_STATE, C_LC_T, C_IMAGE,
       C_COUNTS, C_NEXT_TILE, C_N };

typedef struct {
    const opencl_runtime *rt;
    cl_program program;
    cl_kernel kernel;
    cl_mem buf[C_N];
    char *source;
    uint32_t *counts;
    dilated_grid skip;
} cone_state;

static void release(cone_state *st)
{
    for (int i = 0; i < C_N; i++)
        if (st->buf[i])
            clReleaseMemObject(st->buf[i]);
    if (st->kernel)
        clReleaseKernel(st->kernel);
    if (st->program)
        clReleaseProgram(st->program);
    free(st->source);
    free(st->counts);
    dilated_free(&st->skip);
}

static int buffer(cone_state *st, int which, cl_mem_flags flags, size_t bytes, const void *host, vx_err *e)
{
    st->buf[which] = opencl_buffer(st->rt, flags, bytes, host, e);
    return st->buf[which] ? 0 : -1;
}

static int zero_buffer(cone_state *st, int which, size_t bytes, vx_err *e)
{
    cl_uint zero = 0;
    cl_int err = clEnqueueFillBuffer(st->rt->queue, st->buf[which], &zero, sizeof zero, 0, bytes, 0, NULL, NULL);
    return opencl_check(err, "clearing a buffer", e);
}

static int compile(cone_state *st, const vx_model *m, const char *build_dir, vx_err *e)
{
    if (m->cl_source[0] == '/' || strstr(m->cl_source, ".."))
        return vx_fail(e, "model %s: cl_source \"%s\" must name a header under models/", m->name, m->cl_source);
    char root[4 * PATH_MAX];
    snprintf(root, sizeof root,
             "/* voxlab OpenCL cone program for model %s (assembled by tracer/backends/opencl/opencl_cone.c) */\n"
             "#define VX_CL_CONE_ELEMENT %s\n"
             "#define VX_CL_PARAMS_BYTES %zu\n"
             "#include \"prelude.h\"\n"
             "#include \"%s\"\n"
             "#include \"render_cone.cl\"\n",
             m->name, m->cl_cone_element, sizeof(vx_cl_cone_params), m->cl_source);
    st->source = opencl_program_expand(root, e);
    if (!st->source)
        return -1;
    char what[128], log_path[PATH_MAX + 64];
    snprintf(what, sizeof what, "model %s", m->name);
    snprintf(log_path, sizeof log_path, "%s/opencl-build-%s.log", build_dir, m->name);
    if (opencl_build(st->rt, st->source, what, log_path, &st->program, e))
        return -1;
    cl_int err;
    st->kernel = clCreateKernel(st->program, "vx_render_cone", &err);
    return st->kernel ? 0 : opencl_check(err, "creating kernel vx_render_cone", e);
}

static void fill_params(vx_cl_cone_params *p, const scene *s, const voxel_grid *g, const dilated_grid *d,
                        const render_options *o, size_t lc_slots)
{
    memset(p, 0, sizeof *p);
    vx_cl_grid_params_fill(&p->grid, g);
    uint64_t dil = 0;
    for (int l = 0; l < g->levels; l++) {
        p->dilated_off[l] = dil;
        p->dilated_n[l] = d->level[l].w ? d->level[l].n : 0;
        p->dilated_wpc[l] = d->level[l].w ? d->level[l].wpc : 0;
        dil += dilated_words(d, l);
    }
    p->cam = s->camera;
    p->background = s->background;
    p->light_count = s->light_count < VX_MAX_LIGHTS ? s->light_count : VX_MAX_LIGHTS;
    for (int i = 0; i < p->light_count; i++)
        p->lights[i] = s->lights[i];
    p->spread = camera_pixel_spread(&s->camera, o->height);
    p->width = o->width;
    p->height = o->height;
    p->effects = s->effects;
    /* The same rule as the C backend (render.c): shadows declared, lights, the cache on. */
    p->use_light_cache = o->cache && (s->effects & EFFECT_SHADOWS) && p->light_count > 0;
    p->light_cache_mask = lc_slots - 1;
}

/* Grid tables, level after level (offsets in the parameters), and the dilated bitmaps likewise.
 * The writes are queued without blocking and complete at render_cone's clFinish (the host arrays
 * outlive it): a blocking write per table per level was ~30 round trips to PoCL's worker threads,
 * ~2 ms, most of the host time of a spheres render. */
static int upload_grid(cone_state *st, const voxel_grid *g, vx_err *e)
{
    size_t cols = 0, words = 0, dil = 0;
    for (int l = 0; l < g->levels; l++) {
        cols += (size_t)g->level[l].n * (size_t)g->level[l].n;
        words += g->level[l].words;
        dil += dilated_words(&st->skip, l);
    }
    if (buffer(st, C_COLS, CL_MEM_READ_ONLY, cols * sizeof(uint64_t), NULL, e) ||
        buffer(st, C_BITS, CL_MEM_READ_ONLY, words * sizeof(uint64_t), NULL, e) ||
        buffer(st, C_PREFIX, CL_MEM_READ_ONLY, words * sizeof(uint32_t), NULL, e) ||
        buffer(st, C_DILATED, CL_MEM_READ_ONLY, dil * sizeof(uint64_t), NULL, e))
        return -1;
    cl_command_queue q = st->rt->queue;
    size_t c = 0, w = 0, dw = 0;
    for (int l = 0; l < g->levels; l++) {
        const grid_level *L = &g->level[l];
        size_t nc = (size_t)L->n * (size_t)L->n, nd = dilated_words(&st->skip, l);
        cl_int err = clEnqueueWriteBuffer(q, st->buf[C_COLS], CL_FALSE, c * sizeof(uint64_t), nc * sizeof(uint64_t),
                                          L->cols, 0, NULL, NULL);
        if (err == CL_SUCCESS && L->words)
            err = clEnqueueWriteBuffer(q, st->buf[C_BITS], CL_FALSE, w * sizeof(uint64_t), L->words * sizeof(uint64_t),
                                       L->bits, 0, NULL, NULL);
        if (err == CL_SUCCESS && L->words)
            err = clEnqueueWriteBuffer(q, st->buf[C_PREFIX], CL_FALSE, w * sizeof(uint32_t),
                                       L->words * sizeof(uint32_t), L->prefix, 0, NULL, NULL);
        if (err == CL_SUCCESS && nd)
            err = clEnqueueWriteBuffer(q, st->buf[C_DILATED], CL_FALSE, dw * sizeof(uint64_t), nd * sizeof(uint64_t),
                                       st->skip.level[l].w, 0, NULL, NULL);
        if (opencl_check(err, "uploading the grid", e))
            return -1;
        c += nc;
        w += L->words;
        dw += nd;
    }
    return 0;
}

/* Runs vx_render_cone over n pixels as `groups` work-groups (the tile counter reset first) and
 * waits for it. */
static int run(cone_state *st, size_t groups, int n, const char *what, vx_err *e)
{
    if (zero_buffer(st, C_NEXT_TILE, sizeof(cl_int), e))
        return -1;
    cl_int err = CL_SUCCESS;
    for (int i = 0; i < C_N && err == CL_SUCCESS; i++)
        err = clSetKernelArg(st->kernel, (cl_uint)i, sizeof(cl_mem), &st->buf[i]);
    if (err == CL_SUCCESS)
        err = clSetKernelArg(st->kernel, C_N, sizeof(int), &n);
    size_t local = CONE_LOCAL_SIZE, max = 0;
    if (clGetKernelWorkGroupInfo(st->kernel, st->rt->device, CL_KERNEL_WORK_GROUP_SIZE, sizeof max, &max, NULL) ==
            CL_SUCCESS &&
        max > 0 && max < local)
        local = max;
    size_t global = groups * local;
    if (err == CL_SUCCESS)
        err = clEnqueueNDRangeKernel(st->rt->queue, st->kernel, 1, NULL, &global, &local, 0, NULL, NULL);
    if (err == CL_SUCCESS)
        err = clFinish(st->rt->queue);
    return opencl_check(err, what, e);
}

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int render_cone(cone_state *st, const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                       const render_options *o, image *out, render_counts *counts, opencl_counts *oc,
                       const char *build_dir, vx_err *e)
{
    size_t pixels = (size_t)o->width * (size_t)o->height;
    /* Built before the clock starts, as the C backend (render.c) builds its own: a like-for-like
     * render time. Their upload stays timed. */
    if (dilated_build(&st->skip, g))
        return vx_fail(e, "out of memory for the cone marcher's occupancy bitmaps");
    double t0 = now_seconds();
    if (compile(st, m, build_dir, e))
        return -1;
    double t_compiled = now_seconds();
    size_t groups = st->rt->compute_units ? st->rt->compute_units : 1, slot_bytes = 2 * VX_CONE_COUNTERS * sizeof(uint32_t);
    st->counts = calloc(groups, slot_bytes);
    if (!st->counts)
        return vx_fail(e, "out of memory for the render's counters");
    size_t lc_slots = cone_light_cache_slots(cone_light_cache_cells(grid_count(g, 0), pixels));
    vx_cl_cone_params params;
    fill_params(&params, s, g, &st->skip, o, lc_slots);
    size_t lc = params.use_light_cache ? lc_slots : 0, lights = params.light_count > 0 ? (size_t)params.light_count : 1;
    size_t record_count = 0;
    for (int l = 0; l < (m->uses_levels ? g->levels : 1); l++)
        record_count += grid_count(g, l);
    size_t table_bytes = 0;
    const void *table = m->table ? m->table(&table_bytes) : NULL;
    /* The records and the table are used in place (they outlive the render): on a CPU device
     * (PoCL) no copy, as the C backend reads them; a GPU's driver copies them as before. */
    const cl_mem_flags RO = CL_MEM_READ_ONLY, RW = CL_MEM_READ_WRITE;
    if (buffer(st, C_PARAMS, RO, sizeof params, &params, e) || upload_grid(st, g, e) ||
        buffer(st, C_RECORDS, RO | CL_MEM_USE_HOST_PTR, record_count * m->voxel_bytes, records, e) ||
        buffer(st, C_TABLE, RO | CL_MEM_USE_HOST_PTR, table_bytes, table, e) ||
        buffer(st, C_LC_KEYS, RW, lc * sizeof(uint64_t), NULL, e) ||
        buffer(st, C_LC_STATE, RW, lc * sizeof(cl_int), NULL, e) ||
        buffer(st, C_LC_T, RW, lc * lights * sizeof(float), NULL, e) ||
        buffer(st, C_IMAGE, CL_MEM_WRITE_ONLY, pixels * 3 * sizeof(float), NULL, e) ||
        buffer(st, C_COUNTS, RW, groups * slot_bytes, st->counts, e) ||
        buffer(st, C_NEXT_TILE, RW, sizeof(cl_int), NULL, e))
        return -1;
    if (lc && (zero_buffer(st, C_LC_KEYS, lc * sizeof(uint64_t), e) || zero_buffer(st, C_LC_STATE, lc * sizeof(cl_int), e)))
        return -1;
    /* The uploads and clears complete now, inside the render's time: left queued they would run
     * in the warm-up launch below, which counts as compile time. */
    if (opencl_check(clFinish(st->rt->queue), "uploading the grid and clearing the light cache", e))
        return -1;
    double t_bound = now_seconds();
    /* A launch with nothing to do: PoCL compiles the work-group function at the first launch, and
     * that belongs to the compile time, not to the render. */
    if (run(st, groups, 0, "preparing vx_render_cone", e))
        return -1;
    double t_warm = now_seconds(), cpu_warm = cpu_seconds();
    if (run(st, groups, (int)pixels, "running vx_render_cone", e))
        return -1;
    double t_traced = now_seconds();
    oc->kernel_cpu_seconds = cpu_seconds() - cpu_warm;
    cl_int err = clEnqueueReadBuffer(st->rt->queue, st->buf[C_IMAGE], CL_TRUE, 0, pixels * 3 * sizeof(float), out->data,
                                     0, NULL, NULL);
    if (err == CL_SUCCESS)
        err = clEnqueueReadBuffer(st->rt->queue, st->buf[C_COUNTS], CL_TRUE, 0, groups * slot_bytes, st->counts, 0, NULL,
                                  NULL);
    if (opencl_check(err, "reading the image back", e))
        return -1;
    double t_done = now_seconds();
    uint64_t sums[VX_CONE_COUNTERS] = {0};
    for (size_t gi = 0; gi < groups; gi++)
        for (int k = 0; k < VX_CONE_COUNTERS; k++) {
            const uint32_t *w = &st->counts[(gi * VX_CONE_COUNTERS + (size_t)k) * 2];
            sums[k] += (uint64_t)w[0] | (uint64_t)w[1] << 32;
        }
    memset(counts, 0, sizeof *counts);
    counts->rays = pixels; /* one cone per pixel */
    counts->voxel_visits = sums[VX_CONE_ELEMENTS];
    counts->shadow_rays = sums[VX_CONE_SHADOW_RAYS];
    counts->model_evals = sums[VX_CONE_EVALS];
    counts->cache_hits = sums[VX_CONE_CACHE_HITS];
    oc->compile_seconds = (t_compiled - t0) + (t_warm - t_bound);
    oc->kernel_seconds = t_traced - t_warm;
    counts->seconds = (t_bound - t_compiled) + (t_done - t_warm);
    return 0;
}

int opencl_render_cone(const opencl_runtime *rt, const scene *s, const voxel_grid *g, const vx_model *m,
                       const void *records, const render_options *o, image *out, render_counts *counts,
                       opencl_counts *oc, const char *build_dir, vx_err *e)
{
    if (!m->cl_source || !m->cl_cone_element)
        return vx_fail(e, "model %s cannot run on OpenCL: it marches cones without a portable cone element "
                          "(cl_source, cl_cone_element in models/model.h); use --backend c",
                       m->name);
    cone_state st;
    memset(&st, 0, sizeof st);
    st.rt = rt;
    int rc = render_cone(&st, s, g, m, records, o, out, counts, oc, build_dir, e);
    release(&st);
    return rc;
}
