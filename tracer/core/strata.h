/* Stratified jittered sample positions in a pixel, shared by the ground truth, the C voxel tracer
 * and the OpenCL kernel (tracer/backends/opencl/cl/render.cl includes this file), so all place samples alike.
 * Portable C (no libc beyond <math.h>); in OpenCL C truth_strata's double maths needs cl_khr_fp64,
 * which tracer/backends/opencl/cl/prelude.h enables. */
#ifndef VX_STRATA_H
#define VX_STRATA_H

#include "vec.h"

/* The strata of n samples: a sx * sy grid with sx = floor(sqrt(n)), sy = n / sx. */
VX_INLINE void truth_strata(int n, int *sx, int *sy)
{
    *sx = (int)floor(sqrt((double)n));
    if (*sx < 1)
        *sx = 1;
    *sy = n / *sx;
}

/* The position in [0,1)^2 of sample i in sx * sy strata, jittered by (r1, r2) in [0,1)^2; samples
 * beyond sx * sy are (r1, r2) itself, uniformly random. */
VX_INLINE void truth_strata_sample(int i, int sx, int sy, float r1, float r2, float *x, float *y)
{
    if (i < sx * sy) {
        *x = ((float)(i % sx) + r1) / (float)sx;
        *y = ((float)(i / sx) + r2) / (float)sy;
    } else {
        *x = r1;
        *y = r2;
    }
}

#endif
