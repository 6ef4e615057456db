/* Memory that a timed parallel phase will write, allocated and touched by the calling thread first.
 *
 * Why: calloc's large blocks are fresh mmap pages that the kernel maps on first touch. When the
 * render threads are the first to touch them, each page costs a zero-page fault on the first read,
 * then a copy-on-write fault on the first write with a TLB shootdown of the other cores, all inside
 * the render's clock: binary on city 256^3 gained almost nothing from a second thread (issue 15).
 *
 * Why not malloc + memset(p, 0, n): GCC (-O2, its strlen pass) folds exactly that pair into a
 * calloc, which silently undid the first attempt at this fix. explicit_bzero is never folded or
 * elided. */
#ifndef VX_PREFAULT_H
#define VX_PREFAULT_H

#include <stdlib.h>
#include <string.h>

/* `bytes` bytes (at least one), every page written by this thread: all zero (fill 0) or every byte
 * `fill`. NULL when out of memory; free() it. */
static inline void *vx_alloc_touched(size_t bytes, int fill)
{
    if (!bytes)
        bytes = 1;
    void *p = malloc(bytes);
    if (!p)
        return NULL;
    if (fill == 0)
        explicit_bzero(p, bytes);
    else
        memset(p, fill, bytes);
    return p;
}

#endif
