/* The precomputed shadow maps (tracer/shadows/shadow_maps_core.h) as both OpenCL kernels receive
 * them: the maps' parameters inside the kernel's parameter block, and their arrays as one buffer
 * (the host's shadow_set block, uploaded as it is) whose parts start at the byte offsets below. */
#ifndef VX_CL_SHADOW_PARAMS_H
#define VX_CL_SHADOW_PARAMS_H

#include "shadow_maps_core.h"

typedef struct {
    uint64_t prefix_at, T_at, opaque_at; /* byte offsets in the block (bits start at 0) */
    shadow_maps_params maps;             /* method SHADOW_MARCH, count 0: none */
} vx_cl_shadow_params;

#ifdef __OPENCL_VERSION__
/* The query view of the maps: a work-item's own counter, the arrays in the block. */
static void vx_cl_shadow_maps(shadow_maps *sm, __global const vx_cl_shadow_params *P, __global const uchar *block)
{
    sm->p = &P->maps;
    sm->bits = (__global const ulong *)block;
    sm->prefix = (__global const uint *)(block + P->prefix_at);
    sm->T = (__global const float *)(block + P->T_at);
    sm->opaque = (__global const float *)(block + P->opaque_at);
    sm->queries = 0;
}
#else
#include <string.h>

#include "shadow_set.h"

/* The host's side: set's parameters and offsets (NULL: none). */
static inline void vx_cl_shadow_params_fill(vx_cl_shadow_params *p, const shadow_set *set)
{
    memset(p, 0, sizeof *p);
    if (!set)
        return;
    p->prefix_at = set->prefix_at;
    p->T_at = set->T_at;
    p->opaque_at = set->opaque_at;
    p->maps = set->params;
}
#endif

#endif
