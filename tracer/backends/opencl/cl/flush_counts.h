/* The kernels' counters, summed per work-group: each counter a 64-bit sum in two 32-bit words
 * (low, high) of the group's slot, a carry out of the low word's atomic add going to the high
 * word, so that OpenCL 1.2's 32-bit atomics suffice. Work-items of one group rarely contend (a CPU
 * device runs a group on one thread), and the host reads back one slot per group, not per pixel
 * (opencl_host.c sums them). */
#ifndef VX_CL_FLUSH_COUNTS_H
#define VX_CL_FLUSH_COUNTS_H

/* Adds c to counter k of this work-item's group in `counts` (slots of `counters` counters). */
static void vx_cl_flush_count(__global uint *counts, int counters, int k, ulong c)
{
    __global uint *w = counts + ((size_t)get_group_id(0) * (size_t)counters + (size_t)k) * 2;
    uint lo = (uint)c, hi = (uint)(c >> 32);
    if (lo) {
        uint old = atomic_add(&w[0], lo);
        if (old + lo < old)
            hi++;
    }
    if (hi)
        atomic_add(&w[1], hi);
}

#endif
