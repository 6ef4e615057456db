/* The render counters both OpenCL kernels keep (render_counts' fields), in one order: each kernel
 * adds its work-items' counts per work-group (flush_counts.h) and opencl_host.c sums the groups and
 * fills render_counts from them. */
#ifndef VX_CL_COUNTERS_H
#define VX_CL_COUNTERS_H

enum {
    VX_CL_RAYS, VX_CL_SHADOW_RAYS, VX_CL_VISITS, VX_CL_EVALS, VX_CL_CACHE_HITS, VX_CL_SHADOW_QUERIES, VX_CL_MEMO_HITS,
    VX_CL_COUNTERS
};

#endif
