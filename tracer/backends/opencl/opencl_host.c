#include "opencl_host.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cl/grid_params.h"
#include "opencl_program.h"
#include "parallel.h"

/* Work-group size: a size every device accepts, or the kernel's maximum when that is smaller. */
#define LOCAL_SIZE 64
/* Work-groups per compute unit on a wide launch (a GPU): a multiprocessor keeps up to 2,048
 * work-items resident (32 groups of 64) to hide its memory latency; 16 groups per unit are 135,168
 * work-items on a 132-unit H200, more than the 65,536 pixels of a 256x256 image. */
#define WIDE_GROUPS_PER_UNIT 16

/* CPU time of the whole process (PoCL's worker threads run in it). */
static double opencl_cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int opencl_launch_build(opencl_launch *L, const opencl_runtime *rt, const vx_model *m, const char *defines,
                        const char *kernel_file, const char *kernel_name, int buffers, int next_tile,
                        const char *build_dir, vx_err *e)
{
    memset(L, 0, sizeof *L);
    L->rt = rt;
    L->kernel_name = kernel_name;
    L->buffers = buffers;
    L->next_tile = next_tile;
    L->groups = (rt->compute_units ? rt->compute_units : 1) * (rt->wide ? WIDE_GROUPS_PER_UNIT : 1);
    if (buffers > OPENCL_HOST_MAX_BUFFERS)
        return vx_fail(e, "OpenCL: kernel %s has more than %d buffers", kernel_name, OPENCL_HOST_MAX_BUFFERS);
    size_t defines_len = strlen(defines);
    char *all_defines = malloc(defines_len + 32);
    if (!all_defines)
        return vx_fail(e, "out of memory for the OpenCL program of %s", m->name);
    snprintf(all_defines, defines_len + 32, "%s%s", rt->wide ? "#define VX_CL_WIDE 1\n" : "", defines);
    L->source = opencl_program_text(m, all_defines, kernel_file, e);
    free(all_defines);
    if (!L->source)
        return -1;
    char what[128], log_path[PATH_MAX + 64];
    snprintf(what, sizeof what, "model %s", m->name);
    snprintf(log_path, sizeof log_path, "%s/opencl-build-%s.log", build_dir, m->name);
    if (opencl_build(rt, L->source, what, log_path, &L->program, e))
        return -1;
    cl_int err;
    L->kernel = clCreateKernel(L->program, kernel_name, &err);
    if (!L->kernel) {
        char msg[160];
        snprintf(msg, sizeof msg, "creating kernel %s", kernel_name);
        return opencl_check(err, msg, e);
    }
    size_t max = 0;
    L->local = LOCAL_SIZE;
    if (clGetKernelWorkGroupInfo(L->kernel, rt->device, CL_KERNEL_WORK_GROUP_SIZE, sizeof max, &max, NULL) ==
            CL_SUCCESS &&
        max > 0 && max < L->local)
        L->local = max;
    return 0;
}

int opencl_launch_buffer(opencl_launch *L, int which, cl_mem_flags flags, size_t bytes, const void *host, vx_err *e)
{
    L->buf[which] = opencl_buffer(L->rt, flags, bytes, host, e);
    return L->buf[which] ? 0 : -1;
}

int opencl_launch_counters(opencl_launch *L, int which, vx_err *e)
{
    size_t bytes = L->groups * (size_t)VX_CL_COUNTERS * 2 * sizeof(uint32_t);
    L->counts = calloc(1, bytes ? bytes : 1);
    if (!L->counts)
        return vx_fail(e, "out of memory for the render's counters");
    return opencl_launch_buffer(L, which, CL_MEM_READ_WRITE, bytes, L->counts, e);
}

int opencl_launch_grid(opencl_launch *L, int cols, int bits, int prefix, const voxel_grid *g, vx_err *e)
{
    size_t ncols = 0, words = 0, dense = 0;
    for (int l = 0; l < g->levels; l++) {
        ncols += (size_t)g->level[l].n * (size_t)g->level[l].n;
        words += g->level[l].words;
        dense += (size_t)vx_cl_dense_words(g, l);
    }
    /* bits: the stored words, then the plain bits (vx_cl_grid_params_fill's offsets) */
    if (opencl_launch_buffer(L, cols, CL_MEM_READ_ONLY, ncols * sizeof(uint64_t), NULL, e) ||
        opencl_launch_buffer(L, bits, CL_MEM_READ_ONLY, (words + dense) * sizeof(uint64_t), NULL, e) ||
        opencl_launch_buffer(L, prefix, CL_MEM_READ_ONLY, words * sizeof(uint32_t), NULL, e))
        return -1;
    return 0;
}

int opencl_launch_grid_upload(opencl_launch *L, int cols, int bits, int prefix, const voxel_grid *g, vx_err *e)
{
    /* Every table goes where the kernels' parameters say it starts: the one statement of the layout. */
    vx_cl_grid_params p;
    vx_cl_grid_params_fill(&p, g);
    cl_command_queue q = L->rt->queue;
    for (int l = 0; l < g->levels; l++) {
        const grid_level *G = &g->level[l];
        size_t nc = (size_t)G->n * (size_t)G->n, nd = (size_t)vx_cl_dense_words(g, l);
        cl_int err = clEnqueueWriteBuffer(q, L->buf[cols], CL_FALSE, p.level_cols[l] * sizeof(uint64_t),
                                          nc * sizeof(uint64_t), G->cols, 0, NULL, NULL);
        if (err == CL_SUCCESS && G->words)
            err = clEnqueueWriteBuffer(q, L->buf[bits], CL_FALSE, p.level_words[l] * sizeof(uint64_t),
                                       G->words * sizeof(uint64_t), G->bits, 0, NULL, NULL);
        if (err == CL_SUCCESS && G->words)
            err = clEnqueueWriteBuffer(q, L->buf[prefix], CL_FALSE, p.level_words[l] * sizeof(uint32_t),
                                       G->words * sizeof(uint32_t), G->prefix, 0, NULL, NULL);
        if (err == CL_SUCCESS && nd)
            err = clEnqueueWriteBuffer(q, L->buf[bits], CL_FALSE, p.level_dense[l] * sizeof(uint64_t),
                                       nd * sizeof(uint64_t), G->dense, 0, NULL, NULL);
        if (opencl_check(err, "uploading the grid", e))
            return -1;
    }
    return 0;
}

int opencl_launch_fill(opencl_launch *L, int which, size_t bytes, uint32_t word, vx_err *e)
{
    if (!bytes)
        return 0;
    cl_uint pattern = word;
    return opencl_check(
        clEnqueueFillBuffer(L->rt->queue, L->buf[which], &pattern, sizeof pattern, 0, bytes, 0, NULL, NULL),
        "clearing a buffer", e);
}

int opencl_launch_zero(opencl_launch *L, int which, size_t bytes, vx_err *e)
{
    return opencl_launch_fill(L, which, bytes, 0, e);
}

int opencl_launch_run(opencl_launch *L, int pixels, const char *what, vx_err *e)
{
    if (opencl_launch_zero(L, L->next_tile, sizeof(cl_int), e))
        return -1;
    cl_int err = CL_SUCCESS;
    for (int i = 0; i < L->buffers && err == CL_SUCCESS; i++)
        err = clSetKernelArg(L->kernel, (cl_uint)i, sizeof(cl_mem), &L->buf[i]);
    if (err == CL_SUCCESS)
        err = clSetKernelArg(L->kernel, (cl_uint)L->buffers, sizeof(int), &pixels);
    size_t local = L->local, global = L->groups * local;
    if (err == CL_SUCCESS)
        err = clEnqueueNDRangeKernel(L->rt->queue, L->kernel, 1, NULL, &global, &local, 0, NULL, NULL);
    if (err == CL_SUCCESS)
        err = clFinish(L->rt->queue);
    return opencl_check(err, what, e);
}

int opencl_launch_results(opencl_launch *L, int image_which, float *out, size_t image_bytes, int counts_which,
                          render_counts *counts, vx_err *e)
{
    cl_command_queue q = L->rt->queue;
    size_t count_bytes = L->groups * (size_t)VX_CL_COUNTERS * 2 * sizeof(uint32_t);
    cl_int err = clEnqueueReadBuffer(q, L->buf[image_which], CL_FALSE, 0, image_bytes, out, 0, NULL, NULL);
    if (err == CL_SUCCESS)
        err = clEnqueueReadBuffer(q, L->buf[counts_which], CL_FALSE, 0, count_bytes, L->counts, 0, NULL, NULL);
    if (err == CL_SUCCESS)
        err = clFinish(q);
    if (opencl_check(err, "reading the image and the counters back", e))
        return -1;
    uint64_t sums[VX_CL_COUNTERS] = {0};
    for (size_t gi = 0; gi < L->groups; gi++)
        for (int k = 0; k < VX_CL_COUNTERS; k++) {
            const uint32_t *w = &L->counts[(gi * (size_t)VX_CL_COUNTERS + (size_t)k) * 2];
            sums[k] += (uint64_t)w[0] | (uint64_t)w[1] << 32;
        }
    counts->rays = sums[VX_CL_RAYS];
    counts->shadow_rays = sums[VX_CL_SHADOW_RAYS];
    counts->voxel_visits = sums[VX_CL_VISITS];
    counts->model_evals = sums[VX_CL_EVALS];
    counts->cache_hits = sums[VX_CL_CACHE_HITS];
    counts->memo_hits = sums[VX_CL_MEMO_HITS];
    counts->shadows.queries = sums[VX_CL_SHADOW_QUERIES];
    return 0;
}

void opencl_launch_release(opencl_launch *L)
{
    for (int i = 0; i < OPENCL_HOST_MAX_BUFFERS; i++)
        if (L->buf[i])
            clReleaseMemObject(L->buf[i]);
    if (L->kernel)
        clReleaseKernel(L->kernel);
    if (L->program)
        clReleaseProgram(L->program);
    free(L->source);
    free(L->counts);
    memset(L, 0, sizeof *L);
}

int opencl_launch_warm_up(opencl_launch *L, opencl_clock *c, vx_err *e)
{
    char what[96];
    snprintf(what, sizeof what, "preparing %s", L->kernel_name);
    if (opencl_launch_run(L, 0, what, e))
        return -1;
    c->warm = c->set_up = now_seconds();
    c->cpu_set_up = opencl_cpu_seconds();
    return 0;
}

int opencl_launch_set_up(opencl_launch *L, opencl_clock *c, const char *what, vx_err *e)
{
    if (opencl_check(clFinish(L->rt->queue), what, e))
        return -1;
    c->set_up = now_seconds();
    c->cpu_set_up = opencl_cpu_seconds();
    return 0;
}

int opencl_launch_render(opencl_launch *L, const opencl_clock *c, int pixels, const char *what, int image_which,
                         float *out, int counts_which, render_counts *counts, backend_counts *bc, vx_err *e)
{
    if (opencl_launch_run(L, pixels, what, e))
        return -1;
    double traced = now_seconds();
    bc->kernel_cpu_seconds = opencl_cpu_seconds() - c->cpu_set_up;
    memset(counts, 0, sizeof *counts);
    if (opencl_launch_results(L, image_which, out, (size_t)pixels * 3 * sizeof(float), counts_which, counts, e))
        return -1;
    double done = now_seconds();
    bc->compile_seconds = (c->compiled - c->start) + (c->warm - c->bound);
    bc->kernel_seconds = traced - c->set_up;
    counts->seconds = done - c->set_up;
    counts->setup_seconds = (c->bound - c->compiled) + (c->set_up - c->warm);
    return 0;
}
