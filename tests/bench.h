/* Helpers shared by the benchmarks (tests/bench_*.c): machines are shared and noisy, so every
 * figure is a median. */
#ifndef VX_BENCH_H
#define VX_BENCH_H

#include <stdlib.h>

static int bench_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median of v[0..n) (sorts v in place). */
static inline double bench_median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, bench_cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* The lower and upper quartiles of v[0..n) (sorts v in place): v[n / 4] and v[3n / 4] once sorted, so
 * for 5 values the 2nd and the 4th. Printed beside a median, they show how far the rounds agreed. */
static inline void bench_quartiles(double *v, int n, double *lo, double *hi)
{
    qsort(v, (size_t)n, sizeof *v, bench_cmp_double);
    *lo = v[n / 4];
    *hi = v[3 * n / 4];
}

/* The median of the ratios num[i] / den[i] of n same-round pairs (n at most 64; num and den are left
 * as they are), and their quartiles: a ratio of two times measured seconds apart, so that the shared
 * machine's drift over a run (a fifth within minutes) moves both of a pair alike, where a ratio of
 * two medians mixes rounds. */
static inline double bench_paired_ratio(const double *num, const double *den, int n, double *lo, double *hi)
{
    double r[64];
    n = n < 64 ? n : 64;
    for (int i = 0; i < n; i++)
        r[i] = den[i] > 0 ? num[i] / den[i] : 0.0;
    bench_quartiles(r, n, lo, hi);
    return bench_median(r, n);
}

#endif
