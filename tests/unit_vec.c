/* tracer/core/vec.h's vx_fminf, vx_fmaxf, vx_fmin, vx_fmax (issue 15: libm's are calls on the
 * render's hot path) against libm's fminf, fmaxf, fmin, fmax, bit for bit: every pair of special
 * values (signed zeros, infinities, NaNs, subnormals, neighbours) and random pairs. A NaN result
 * must be a NaN (its payload aside); every other result must have libm's bits, so the renderer's
 * images and records cannot change with the swap. The libm calls go through volatile function
 * pointers, so that GCC cannot fold them into the same comparisons as the inline versions. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rng.h"
#include "unit.h"
#include "vec.h"

static float (*volatile libm_fminf)(float, float) = fminf;
static float (*volatile libm_fmaxf)(float, float) = fmaxf;
static double (*volatile libm_fmin)(double, double) = fmin;
static double (*volatile libm_fmax)(double, double) = fmax;

static int same_f(float a, float b) { return (a != a && b != b) || memcmp(&a, &b, sizeof a) == 0; }
static int same_d(double a, double b) { return (a != a && b != b) || memcmp(&a, &b, sizeof a) == 0; }

/* Mismatches of the four functions on (a, b). */
static int compare(double a, double b)
{
    float fa = (float)a, fb = (float)b;
    return !same_f(vx_fminf(fa, fb), libm_fminf(fa, fb)) + !same_f(vx_fmaxf(fa, fb), libm_fmaxf(fa, fb)) +
           !same_d(vx_fmin(a, b), libm_fmin(a, b)) + !same_d(vx_fmax(a, b), libm_fmax(a, b));
}

int main(void)
{
    const double special[] = {0.0, -0.0, 1.0, -1.0, NAN, -NAN, INFINITY, -INFINITY, 1e-40, -1e-40,
                              1e-310, -1e-310, 1.0000001, 0.9999999, 3.4e38, -3.4e38, 1e300, -1e300};
    const int n = (int)(sizeof special / sizeof special[0]);
    int bad = 0, pairs = 0;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++, pairs++)
            bad += compare(special[i], special[j]);
    char name[160];
    snprintf(name, sizeof name, "vx_fmin/fmax(f) equal libm's on %d pairs of special values (%d differ)", pairs, bad);
    CHECK(name, bad == 0);

    rng g = rng_seed(15, 7);
    bad = 0;
    for (int k = 0; k < 100000; k++) {
        double a = 4.0 * rng_float(&g) - 2.0, b = k % 3 ? 4.0 * rng_float(&g) - 2.0 : a; /* ties a third of the time */
        bad += compare(a, b);
    }
    snprintf(name, sizeof name, "vx_fmin/fmax(f) equal libm's on 100000 random pairs, a third of them ties (%d differ)",
             bad);
    CHECK(name, bad == 0);

    /* The cases that tell the versions apart (else the checks above could pass with any tie rule). */
    float z = vx_fminf(0.0f, -0.0f);
    double zd = vx_fmin(0.0, -0.0);
    CHECK("vx_fminf(+0, -0) is -0 (the second argument, as glibc's)", signbit(z));
    CHECK("vx_fmin(+0, -0) is -0 (the second argument, as glibc's)", signbit(zd));
    CHECK("a NaN argument gives the other one", vx_fmaxf(NAN, 2.0f) == 2.0f && vx_fmaxf(2.0f, NAN) == 2.0f &&
                                                    vx_fmin(NAN, -3.0) == -3.0 && vx_fmin(-3.0, NAN) == -3.0);
    return unit_exit();
}
