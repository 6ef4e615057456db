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

/* The threads that parallel_for hands items to, kept for the life of the process. Why not a
 * thread per call, as before: a frame makes three parallel_for calls (the depth bounds' shares,
 * their merge, the bands of rows), and a new thread took about 0.15 ms to start taking items
 * (bunny 256^3, binary, 2 threads: 0.47 ms of a 13.7 ms frame during which one core waited). A
 * kept thread sleeps on a condition variable: it took up to 40 us to start on the frame's second
 * and third calls, 90-120 us on its first (after the gap between frames; a virtual machine, whose
 * idle core halts).
 * The items' results depend only on the items (parallel.h), so which thread runs them changes no
 * output.
 * One caller at a time uses the pool (`busy`); a second caller meanwhile (another thread of a
 * program that renders from several, or a parallel_for called from inside an item) starts threads
 * of its own as before, so that nothing waits on the pool from inside it. */
#define POOL_MAX_HELPERS 255

typedef struct {
    pthread_mutex_t busy;  /* held by the parallel_for that is using the pool */
    pthread_mutex_t m;     /* guards the fields below */
    pthread_cond_t wake;   /* a job was posted (generation moved) */
    pthread_cond_t done;   /* running fell to 0 */
    job *j;                /* the posted job */
    uint64_t generation;   /* how many jobs were posted */
    int helpers;           /* threads started, numbered 1 .. helpers */
    int wanted;            /* the helpers that take part in the posted job: 1 .. wanted */
    int running;           /* of those, how many have not finished it */
} pool;

/* A pool with no helpers and no job: the process's at start, a forked child's (pool_after_fork). */
#define POOL_EMPTY                                                                                   \
    {PTHREAD_MUTEX_INITIALIZER, PTHREAD_MUTEX_INITIALIZER, PTHREAD_COND_INITIALIZER,                 \
     PTHREAD_COND_INITIALIZER, NULL, 0, 0, 0, 0}

static pool the_pool = POOL_EMPTY;
static _Thread_local int on_pool_thread;

typedef struct {
    int thread;
    uint64_t seen; /* the generation posted before this helper started: not its job */
} helper_start;

static helper_start helper_args[POOL_MAX_HELPERS + 1];

static void *helper_main(void *p)
{
    const helper_start *start = p;
    pool *P = &the_pool;
    uint64_t seen = start->seen;
    on_pool_thread = 1;
    for (;;) {
        pthread_mutex_lock(&P->m);
        while (P->generation == seen)
            pthread_cond_wait(&P->wake, &P->m);
        seen = P->generation;
        if (start->thread > P->wanted) {
            pthread_mutex_unlock(&P->m);
            continue; /* a job for fewer threads */
        }
        worker_arg a = {P->j, start->thread};
        pthread_mutex_unlock(&P->m);
        worker(&a);
        pthread_mutex_lock(&P->m);
        if (--P->running == 0)
            pthread_cond_signal(&P->done);
        pthread_mutex_unlock(&P->m);
    }
    return NULL;
}

/* A forked child has only the thread that forked: its pool starts empty (the parent's helpers, and
 * whatever they held, are not there). */
static void pool_after_fork(void)
{
    pool fresh = POOL_EMPTY;
    the_pool = fresh;
    on_pool_thread = 0;
}

static void pool_register_fork(void) { pthread_atfork(NULL, NULL, pool_after_fork); }

/* Runs job j on the calling thread (thread 0) and threads - 1 helpers of the pool, starting those
 * it lacks; 0 when done, -1 (nothing run) when the pool is in use. */
static int pool_run(job *j, int threads)
{
    static pthread_once_t once = PTHREAD_ONCE_INIT;
    pool *P = &the_pool;
    if (on_pool_thread || pthread_mutex_trylock(&P->busy) != 0)
        return -1;
    pthread_once(&once, pool_register_fork);
    pthread_mutex_lock(&P->m);
    while (P->helpers < threads - 1 && P->helpers < POOL_MAX_HELPERS) {
        helper_start *h = &helper_args[P->helpers + 1];
        h->thread = P->helpers + 1;
        h->seen = P->generation;
        pthread_t tid;
        pthread_attr_t attr;
        pthread_attr_init(&attr);
        pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
        int rc = pthread_create(&tid, &attr, helper_main, h);
        pthread_attr_destroy(&attr);
        if (rc != 0)
            break; /* a thread that cannot be started is simply not there: the others drain the items */
        P->helpers++;
    }
    int helpers = threads - 1 < P->helpers ? threads - 1 : P->helpers;
    P->j = j;
    P->wanted = helpers;
    P->running = helpers;
    P->generation++;
    pthread_cond_broadcast(&P->wake);
    pthread_mutex_unlock(&P->m);
    worker_arg a = {j, 0};
    worker(&a);
    pthread_mutex_lock(&P->m);
    while (P->running > 0)
        pthread_cond_wait(&P->done, &P->m);
    P->j = NULL;
    pthread_mutex_unlock(&P->m);
    pthread_mutex_unlock(&P->busy);
    return 0;
}

/* The job on threads started for this call alone (when the pool is in use; none for one thread). */
static void spawn_run(job *j, int threads)
{
    pthread_t *tids = malloc(sizeof(pthread_t) * (size_t)threads);
    worker_arg *args = malloc(sizeof(worker_arg) * (size_t)threads);
    int started = 1;
    for (int t = 0; t < threads; t++) {
        if (args)
            args[t] = (worker_arg){j, t};
        /* A thread that cannot be created is simply not there: thread 0 drains the queue anyway. */
        if (t > 0 && tids && args && pthread_create(&tids[started], NULL, worker, &args[t]) == 0)
            started++;
    }
    worker_arg self = {j, 0};
    worker(&self);
    for (int t = 1; t < started; t++)
        pthread_join(tids[t], NULL);
    free(tids);
    free(args);
}

static void prestart_item(void *ctx, int64_t item, int thread) { (void)ctx, (void)item, (void)thread; }

void parallel_prestart(int threads)
{
    /* The pool's helpers were started by a pool_run, which waits until each has taken part: when it
     * has enough of them, nothing is left to start (a job would only wake them). */
    pthread_mutex_lock(&the_pool.m);
    int helpers = the_pool.helpers;
    pthread_mutex_unlock(&the_pool.m);
    if (threads <= 1 || helpers >= threads - 1 || helpers >= POOL_MAX_HELPERS)
        return;
    /* One item a thread: pool_run starts the helpers it lacks and returns once each has taken part. */
    parallel_for(threads, threads, prestart_item, NULL, NULL);
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
    if (threads == 1 || pool_run(&j, threads) != 0)
        spawn_run(&j, threads);
    if (j.label) {
        show_progress(&j, count);
        fputc('\n', stderr);
    }
}
