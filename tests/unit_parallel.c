/* tracer/core/parallel.c's parallel_for, whose threads are kept from call to call (a pool): every
 * item runs exactly once, on a thread index below the threads asked for, whatever the count and
 * the threads; the second thread is one and the same thread over successive calls (the pool: a
 * thread per call would be a new one each time) and does take items; a parallel_for called from
 * inside an item, two callers at once and a forked child all finish with every item run; and two
 * thousand short calls in a row lose no wake-up (a lost one hangs: the alarm turns that into a
 * failure). First of all, in a process with no thread started yet: parallel_prestart starts the pool's
 * helpers there and then, so that the parallel_for after it (a timed one) starts none. */
#include <dirent.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "parallel.h"
#include "unit.h"

#define MAX_ITEMS 1000

typedef struct {
    atomic_int runs[MAX_ITEMS];
    atomic_int worst_thread; /* the largest thread index seen */
} tally;

static void count_item(void *p, int64_t item, int thread)
{
    tally *t = p;
    atomic_fetch_add(&t->runs[item], 1);
    int w = atomic_load(&t->worst_thread);
    while (thread > w && !atomic_compare_exchange_weak(&t->worst_thread, &w, thread))
        ;
}

/* Whether parallel_for(count, threads) ran every item once, on threads below `threads`. */
static int runs_each_once(int64_t count, int threads)
{
    static tally t;
    for (int i = 0; i < MAX_ITEMS; i++)
        atomic_init(&t.runs[i], 0);
    atomic_init(&t.worst_thread, -1);
    parallel_for(count, threads, count_item, &t, NULL);
    for (int64_t i = 0; i < count; i++)
        if (atomic_load(&t.runs[i]) != 1)
            return 0;
    for (int64_t i = count; i < MAX_ITEMS; i++)
        if (atomic_load(&t.runs[i]) != 0)
            return 0;
    int worst = atomic_load(&t.worst_thread);
    return count == 0 ? worst == -1 : worst >= 0 && worst < threads;
}

/* The threads the process has now (the entries of /proc/self/task), or -1 when that cannot be read. */
static int process_threads(void)
{
    DIR *d = opendir("/proc/self/task");
    if (!d)
        return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        n += e->d_name[0] != '.';
    closedir(d);
    return n;
}

static void nothing(void *p, int64_t item, int thread) { (void)p, (void)item, (void)thread; }

/* Items that take a while, recording which thread ran them. */
typedef struct {
    atomic_int taken_by_1;
    pid_t thread_1; /* the kernel's id: glibc hands a new thread the descriptor (pthread_t) of one that ended */
} helper_seen;

static void slow_item(void *p, int64_t item, int thread)
{
    (void)item;
    helper_seen *h = p;
    if (thread == 1) {
        h->thread_1 = gettid(); /* only thread 1 writes it */
        atomic_fetch_add(&h->taken_by_1, 1);
    }
    usleep(500);
}

typedef struct {
    atomic_int inner;
} nested;

static void inner_item(void *p, int64_t item, int thread)
{
    (void)item, (void)thread;
    atomic_fetch_add(&((nested *)p)->inner, 1);
}

static void outer_item(void *p, int64_t item, int thread)
{
    (void)item, (void)thread;
    parallel_for(100, 2, inner_item, p, NULL);
}

static void *concurrent_caller(void *p)
{
    for (int k = 0; k < 50; k++)
        parallel_for(100, 2, inner_item, p, NULL);
    return NULL;
}

int main(void)
{
    /* A hang (a lost wake-up, a deadlock) ends the test with SIGALRM instead of blocking the suite. */
    alarm(120);
    int alone = process_threads();
    parallel_prestart(1);
    int after_one = process_threads();
    parallel_prestart(3);
    int after_three = process_threads();
    parallel_for(64, 3, nothing, NULL, NULL);
    parallel_prestart(3);
    int after_calls = process_threads();
    printf("# threads: %d at start, %d after parallel_prestart(1), %d after parallel_prestart(3), %d after a "
           "parallel_for on 3 and parallel_prestart(3) again\n", alone, after_one, after_three, after_calls);
    CHECK("parallel_prestart(1) starts no thread", alone == 1 && after_one == 1);
    CHECK("parallel_prestart(3) starts the two helpers before it returns", alone == 1 && after_three == 3);
    CHECK("a parallel_for on 3 threads after it, and parallel_prestart again, start none", after_calls == 3);
    const int64_t counts[] = {0, 1, 2, 3, 7, 64, 1000};
    const int threads[] = {1, 2, 3, 8, 300};
    int wrong = 0, cases = 0;
    for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++)
        for (size_t t = 0; t < sizeof threads / sizeof threads[0]; t++, cases++)
            wrong += !runs_each_once(counts[c], threads[t]);
    printf("# %d (count, threads) cases, %d wrong\n", cases, wrong);
    CHECK("every item runs once, on a thread below the threads asked for", wrong == 0);

    helper_seen a, b;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    parallel_for(200, 2, slow_item, &a, NULL);
    parallel_for(200, 2, slow_item, &b, NULL);
    printf("# the second thread took %d and %d of 200 items\n", atomic_load(&a.taken_by_1), atomic_load(&b.taken_by_1));
    CHECK("the second thread takes items", atomic_load(&a.taken_by_1) > 0 && atomic_load(&b.taken_by_1) > 0);
    CHECK("the second thread is kept from call to call",
          atomic_load(&a.taken_by_1) > 0 && atomic_load(&b.taken_by_1) > 0 && a.thread_1 == b.thread_1);

    nested n;
    atomic_init(&n.inner, 0);
    parallel_for(4, 2, outer_item, &n, NULL);
    CHECK("a parallel_for inside an item finishes, every item run", atomic_load(&n.inner) == 400);

    nested m;
    atomic_init(&m.inner, 0);
    pthread_t other;
    int started = pthread_create(&other, NULL, concurrent_caller, &m) == 0;
    concurrent_caller(&m);
    if (started)
        pthread_join(other, NULL);
    CHECK("two callers at once both finish, every item run", started && atomic_load(&m.inner) == 2 * 50 * 100);

    int lost = 0;
    for (int k = 0; k < 2000; k++)
        lost += !runs_each_once(3, 2);
    CHECK("2000 short calls in a row, every item run", lost == 0);

    /* A child forked while the parent's pool has a thread has only the forking thread: its pool
     * must start afresh, not wait for threads that are not there. */
    fflush(stdout);
    pid_t pid = fork();
    if (pid == 0) {
        alarm(20);
        _exit(runs_each_once(1000, 2) && runs_each_once(64, 3) ? 0 : 1);
    }
    int status = 0;
    int waited = pid > 0 && waitpid(pid, &status, 0) == pid;
    CHECK("a forked child's parallel_for finishes, every item run", waited && WIFEXITED(status) && WEXITSTATUS(status) == 0);
    return unit_exit();
}
