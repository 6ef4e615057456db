#include "parallel.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

double now_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int parallel_threads(int requested)
{
    if (requested > 0)
        return requested;
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

typedef struct {
    parallel_fn fn;
    void *ctx;
    int64_t count;
    atomic_llong next, done;
    const char *label;
    double start;
} job;

typedef struct {
    job *j;
    int thread;
} worker_arg;

static void show_progress(job *j, int64_t done)
{
    double elapsed = now_seconds() - j->start;
    double eta = done > 0 ? elapsed * (double)(j->count - done) / (double)done : 0.0;
    fprintf(stderr, "\r%s: %3d%%  %.1fs elapsed, ~%.1fs left   ", j->label, (int)(100 * done / j->count), elapsed, eta);
}

static void *worker(void *p)
{
    worker_arg *a = p;
    job *j = a->j;
    int64_t last_shown = -1;
    for (;;) {
        int64_t i = atomic_fetch_add(&j->next, 1);
        if (i >= j->count)
            break;
        j->fn(j->ctx, i, a->thread);
        int64_t done = atomic_fetch_add(&j->done, 1) + 1;
        /* Only thread 0 draws, at most a hundred times, so output never interleaves. */
        if (j->label && a->thread == 0 && done * 100 / j->count != last_shown) {
            last_shown = done * 100 / j->count;
            show_progress(j, done);
        }
    }
    return NULL;
}

void parallel_for(int64_t count, int threads, parallel_fn fn, void *ctx, const char *label)
{
    if (count <= 0)
        return;
    job j = {.fn = fn, .ctx = ctx, .count = count, .label = label && isatty(2) ? label : NULL, .start = now_seconds()};
    atomic_init(&j.next, 0);
    atomic_init(&j.done, 0);
    if (threads > count)
        threads = (int)count;
    if (threads < 1)
        threads = 1;
    pthread_t *tids = malloc(sizeof(pthread_t) * (size_t)threads);
    worker_arg *args = malloc(sizeof(worker_arg) * (size_t)threads);
    int started = 1;
    for (int t = 0; t < threads; t++) {
        args[t] = (worker_arg){&j, t};
        /* A thread that cannot be created is simply not there: thread 0 drains the queue anyway. */
        if (t > 0 && pthread_create(&tids[started], NULL, worker, &args[t]) == 0)
            started++;
    }
    worker(&args[0]);
    for (int t = 1; t < started; t++)
        pthread_join(tids[t], NULL);
    if (j.label) {
        show_progress(&j, count);
        fputc('\n', stderr);
    }
    free(tids);
    free(args);
}
