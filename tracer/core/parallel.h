/* A thread pool: items are handed out dynamically, but every item's result must depend only on the
 * item (never on the thread), which keeps renders deterministic for any thread count. The threads
 * are kept from call to call (parallel.c says why). */
#ifndef VX_PARALLEL_H
#define VX_PARALLEL_H

#include <stdint.h>

typedef void (*parallel_fn)(void *ctx, int64_t item, int thread);

/* Number of threads to use: `requested` when > 0, else the online CPU count. */
int parallel_threads(int requested);

/* Runs fn(ctx, i, thread) for i in [0, count) on `threads` threads (thread 0 the caller; thread
 * numbers below min(threads, count)). Safe to call from inside fn and from several threads at once.
 * When `label` is not NULL and stderr is a terminal, shows "label: NN%" progress there. */
void parallel_for(int64_t count, int threads, parallel_fn fn, void *ctx, const char *label);

/* Starts now the threads that a parallel_for on `threads` threads will use (the pool's helpers), each
 * run once, so that a clock started next does not count their start: a timed region calls it before
 * its clock. A new thread's stack and its copy of the thread-local storage (vmesh's kept views, 267 kB)
 * are made and first touched when it starts: on a render's first parallel_for, 73 page faults and
 * 1.2 ms of binary's frame (11.1 ms, 9.9 without them; bunny 256^3 from a .vox, 2 threads), while
 * the truth's clock found its thread already started. Nothing to do when they run already (or for
 * one thread). */
void parallel_prestart(int threads);

/* Seconds from a monotonic clock. */
double now_seconds(void);

#endif
