/* Small double-precision helpers on double[3] arrays, for host code that needs more than vec3's
 * floats (the grid's mapping, the C backend's maps). Host C only (not compiled by OpenCL). */
#ifndef VX_VEC_D_H
#define VX_VEC_D_H

#include <math.h>

static inline double vx_dot3d(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* Half the extent of a unit cube's projection on axis a (its support): (|a.x| + |a.y| + |a.z|) / 2. */
static inline double vx_cube_half_extent(const double a[3]) { return 0.5 * (fabs(a[0]) + fabs(a[1]) + fabs(a[2])); }

/* Where the ray o + t d, for t >= t_start, enters and leaves the closed box [lo, hi] (slab test):
 * 1 with [*t_in, *t_out], 0 when it misses the box. A zero direction component keeps the ray in its
 * slab or misses. */
static inline int vx_ray_box(const double o[3], const double d[3], const double lo[3], const double hi[3], double t_start,
                             double *t_in, double *t_out)
{
    double a = t_start, b = INFINITY;
    for (int k = 0; k < 3; k++) {
        if (d[k] == 0.0) {
            if (o[k] < lo[k] || o[k] > hi[k])
                return 0;
            continue;
        }
        double t0 = (lo[k] - o[k]) / d[k], t1 = (hi[k] - o[k]) / d[k];
        if (t0 > t1) {
            double t = t0;
            t0 = t1;
            t1 = t;
        }
        a = t0 > a ? t0 : a;
        b = t1 < b ? t1 : b;
    }
    *t_in = a;
    *t_out = b;
    return a <= b;
}

#endif
