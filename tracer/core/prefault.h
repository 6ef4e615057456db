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

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

/* The process's minor page faults so far (getrusage; 0 when it fails): a timed phase reports the
 * difference across its clock, which shows memory first touched inside it. */
static inline long vx_minor_faults(void)
{
    struct rusage ru;
    return getrusage(RUSAGE_SELF, &ru) ? 0 : ru.ru_minflt;
}

/* Maps every page of [p, p + bytes) in one system call (MADV_POPULATE_WRITE, Linux 5.14) instead of
 * one fault a page: a fault costs ~11 us on the VMs this runs on, so touching 76 MB of .vox records
 * page by page took ~0.2 s. Only for blocks of 1 MiB and more (malloc maps those itself); a kernel
 * without it, or any failure, leaves the pages to fault in as before. */
static inline void vx_populate(void *p, size_t bytes)
{
#ifdef MADV_POPULATE_WRITE
    if (!p || bytes < ((size_t)1 << 20))
        return;
    uintptr_t page = (uintptr_t)sysconf(_SC_PAGESIZE);
    uintptr_t lo = ((uintptr_t)p + page - 1) & ~(page - 1), hi = ((uintptr_t)p + bytes) & ~(page - 1);
    if (hi > lo)
        (void)madvise((void *)lo, hi - lo, MADV_POPULATE_WRITE);
#else
    (void)p, (void)bytes;
#endif
}

/* `bytes` bytes (at least one), every page written by this thread: all zero (fill 0) or every byte
 * `fill`. NULL when out of memory; free() it.
 *
 * A block of 2 MiB or more is aligned to 2 MiB, rounded up to a multiple of it, and asks for
 * transparent huge pages: one fault each 2 MiB instead of 512, which was most of a render's set-up
 * (the shading cache's 6 MiB on city 256^3 took 9 ms to map; city's set-up fell from 22 to 14 ms,
 * heitz-neyret's from 20 to 16). Where the kernel offers none, the pages are the usual ones. */
static inline void *vx_alloc_touched(size_t bytes, int fill)
{
    if (!bytes)
        bytes = 1;
    void *p = NULL;
#ifdef MADV_HUGEPAGE
    const size_t huge = (size_t)2 << 20;
    if (bytes >= huge) {
        size_t rounded = (bytes + huge - 1) & ~(huge - 1);
        if (posix_memalign(&p, huge, rounded) == 0) {
            (void)madvise(p, rounded, MADV_HUGEPAGE);
            bytes = rounded;
        } else
            p = NULL;
    }
#endif
    if (!p)
        p = malloc(bytes);
    if (!p)
        return NULL;
    vx_populate(p, bytes);
    if (fill == 0)
        explicit_bzero(p, bytes);
    else
        memset(p, fill, bytes);
    return p;
}

#endif
