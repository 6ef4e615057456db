#include "tribox.h"

#include <math.h>

#include "vec_d.h"

static inline double dmin(double a, double b) { return a < b ? a : b; }
static inline double dmax(double a, double b) { return a > b ? a : b; }

static void sub3(double r[3], const double a[3], const double b[3])
{
    r[0] = a[0] - b[0];
    r[1] = a[1] - b[1];
    r[2] = a[2] - b[2];
}

static void cross3(double r[3], const double a[3], const double b[3])
{
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}


/* Separated along `axis` when the triangle's projected interval [min, max] and the box's
 * [-r, r] are disjoint. Strict comparisons: touching intervals are not separated. */
static int separated(const double axis[3], const double v[3][3], const double half[3])
{
    double p0 = vx_dot3d(axis, v[0]), p1 = vx_dot3d(axis, v[1]), p2 = vx_dot3d(axis, v[2]);
    double mn = dmin(p0, dmin(p1, p2)), mx = dmax(p0, dmax(p1, p2));
    double r = half[0] * fabs(axis[0]) + half[1] * fabs(axis[1]) + half[2] * fabs(axis[2]);
    return mn > r || mx < -r;
}

int tribox_overlap_d(const double lo[3], const double hi[3], const double a[3], const double b[3],
                     const double c[3])
{
    /* Work relative to the box centre so the box is symmetric, as in Akenine-Moller's code. */
    double centre[3], half[3], v[3][3], e[3][3];
    for (int i = 0; i < 3; i++) {
        centre[i] = 0.5 * (lo[i] + hi[i]);
        half[i] = 0.5 * (hi[i] - lo[i]);
    }
    sub3(v[0], a, centre);
    sub3(v[1], b, centre);
    sub3(v[2], c, centre);
    /* Box normals first: the cheapest and most often decisive (bounding-box rejection). */
    for (int i = 0; i < 3; i++) {
        double mn = dmin(v[0][i], dmin(v[1][i], v[2][i])), mx = dmax(v[0][i], dmax(v[1][i], v[2][i]));
        if (mn > half[i] || mx < -half[i])
            return 0;
    }
    sub3(e[0], v[1], v[0]);
    sub3(e[1], v[2], v[1]);
    sub3(e[2], v[0], v[2]);
    /* Nine edge x box-normal axes. A zero axis (edge parallel to the box normal, or a zero-length
     * edge) projects everything to 0 and so never separates: no special case needed. */
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            double unit[3] = {0, 0, 0}, axis[3];
            unit[j] = 1.0;
            cross3(axis, e[i], unit);
            if (separated(axis, v, half))
                return 0;
        }
    }
    /* Triangle plane last (for a zero-area triangle the normal is zero and this never separates,
     * leaving the segment/point tests above, which are then complete). */
    double n[3];
    cross3(n, e[0], e[1]);
    return !separated(n, v, half);
}

int tribox_overlap(vec3 lo, vec3 hi, vec3 a, vec3 b, vec3 c)
{
    double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    double pa[3] = {a.x, a.y, a.z}, pb[3] = {b.x, b.y, b.z}, pc[3] = {c.x, c.y, c.z};
    return tribox_overlap_d(l, h, pa, pb, pc);
}

int tribox_cells_setup(tribox_cells *s, const double a[3], const double b[3], const double c[3])
{
    const double *v[3] = {a, b, c};
    double e[3][3];
    sub3(e[0], b, a);
    sub3(e[1], c, b);
    sub3(e[2], a, c);
    cross3(s->n, e[0], e[1]);
    if (s->n[0] == 0.0 && s->n[1] == 0.0 && s->n[2] == 0.0)
        return 0;

    /* Plane: the unit cell at p spans n.p + [sum of negative n_i, sum of positive n_i] along n;
     * it meets the plane n.x = n.a when that interval contains n.a. */
    double na = vx_dot3d(s->n, a), pos = 0.0, neg = 0.0;
    for (int i = 0; i < 3; i++) {
        if (s->n[i] > 0.0)
            pos += s->n[i];
        else
            neg += s->n[i];
    }
    s->plane_lo = na - pos;
    s->plane_hi = na - neg;

    /* Edge functions per projection, oriented inwards by the sign of the dropped normal
     * component. When that component is 0 the projection is a segment: the three edge normals are
     * then parallel and point both ways (the edges sum to zero), so the tests together say "the
     * cell straddles the segment's line", which is what the SAT asks for those axes. C includes
     * the offset to the cell corner that lies furthest inside the edge (the critical corner). */
    for (int ax = 0; ax < 3; ax++) {
        int u = (ax + 1) % 3, w = (ax + 2) % 3;
        double sgn = s->n[ax] >= 0.0 ? 1.0 : -1.0;
        for (int i = 0; i < 3; i++) {
            double A = -e[i][w] * sgn, B = e[i][u] * sgn;
            s->edge[ax][i][0] = A;
            s->edge[ax][i][1] = B;
            s->edge[ax][i][2] = -(A * v[i][u] + B * v[i][w]) + dmax(0.0, A) + dmax(0.0, B);
        }
    }

    int dom = 0;
    for (int i = 0; i < 3; i++) {
        double mn = dmin(a[i], dmin(b[i], c[i])), mx = dmax(a[i], dmax(b[i], c[i]));
        /* Cell k spans [k, k+1]: a minimum exactly on an integer plane also touches the cell
         * below it, hence ceil - 1 rather than floor. The casts are the caller's to keep in
         * range (grid coordinates are within a few cells of [0, 1024]). */
        s->lo[i] = (int)ceil(mn) - 1;
        s->hi[i] = (int)floor(mx);
        if (fabs(s->n[i]) > fabs(s->n[dom]))
            dom = i;
    }
    s->dominant = dom;
    return 1;
}
