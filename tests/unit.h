/* Minimal unit-test helpers: each CHECK prints "ok NAME" or "not ok NAME: why" (the protocol
 * tests/run_all.sh counts), and unit_exit() returns non-zero when any check failed. */
#ifndef VX_UNIT_H
#define VX_UNIT_H

#include <math.h>
#include <stdio.h>

static int unit_failures;

#define CHECK(name, cond)                                                              \
    do {                                                                               \
        if (cond)                                                                      \
            printf("ok %s\n", name);                                                   \
        else {                                                                         \
            printf("not ok %s: %s (%s:%d)\n", name, #cond, __FILE__, __LINE__);      \
            unit_failures++;                                                           \
        }                                                                              \
    } while (0)

#define CHECK_NEAR(name, got, want, tol)                                               \
    do {                                                                               \
        double g_ = (got), w_ = (want), t_ = (tol);                                    \
        if (fabs(g_ - w_) <= t_)                                                       \
            printf("ok %s\n", name);                                                   \
        else {                                                                         \
            printf("not ok %s: got %.9g, want %.9g +- %.3g (%s:%d)\n", name, g_, w_, t_, \
                   __FILE__, __LINE__);                                                \
            unit_failures++;                                                           \
        }                                                                              \
    } while (0)

static inline int unit_exit(void) { return unit_failures ? 1 : 0; }

#endif
