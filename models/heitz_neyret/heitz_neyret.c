/* `heitz-neyret`: Heitz & Neyret 2012, "Representing appearance and pre-filtering subpixel data in
 * sparse voxel octrees". Per cell of every MIP level: the mean surface plane (height h along the
 * mean normal) with its height variance sigma_h^2, the mean normal with the slope variance
 * sigma_n^2, and per colour channel the mean a and the projection a_s of the colour on
 * s(h) = 2 g(h) - 1 (record layout in hn_record.h). Rendered by cone marching: the tracer steps
 * cone elements and calls cone_element, which interpolates the records quadrilinearly, builds the
 * element's 128-sample coverage mask and its view- and light-dependent radiance (hn_eval.h);
 * the tracer composites the masks A-buffer style.
 *
 * This file is the host side: the start-up mask table, the bake (level 0 from the shared sampler's
 * hits, coarser levels from their children) and the glue from the model interface to the portable
 * evaluation in hn_eval.h.
 *
 * Limits, honestly: each element is one plane (or, for a two-sided sheet, the half-space behind it
 * as the viewer sees it) clipped by one edge line (psi, hn_record.h); its coverage bits are all or
 * nothing per sample. A cell holding a cloud of sub-pixel leaves has partial coverage that no plane
 * can represent (HN 2012 §7; Brito et al. 2023 §2): such cells cover as an opaque blob, so foliage
 * comes out denser than the truth at coarse levels. */
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "eigen_sym3.h"
#include "grid.h"
#include "hn_host.h"
#include "rng.h"

/* ---- Coverage-mask table ------------------------------------------------------------------- */

static float mask_samples[2 * HN_MASK_SAMPLES];
static unsigned int mask_table[HN_TABLE_WORDS];
static pthread_once_t tables_once = PTHREAD_ONCE_INIT;

static void random_in_disk(rng *r, double *x, double *y)
{
    double rad = sqrt(rng_double(r)), phi = 2.0 * M_PI * rng_double(r);
    *x = rad * cos(phi);
    *y = rad * sin(phi);
}

/* Poisson-disk samples by Mitchell's best-candidate algorithm (a fixed seed: the masks are the
 * same on every run), relaxed by a few Lloyd iterations over a fine lattice of the disk: best
 * candidate alone crowds the rim (no neighbours beyond it), which biases the covered fractions;
 * the relaxed set is as even inside as at the rim. The render uses the shipped result
 * (hn_mask_points.c); this is where it comes from, and the unit test's check of it. */
void hn_mask_points_generate(double points[HN_MASK_SAMPLES][2])
{
    rng r = rng_seed(0x484e3132ULL /* "HN12" */, 0);
    double px[HN_MASK_SAMPLES], py[HN_MASK_SAMPLES];
    random_in_disk(&r, &px[0], &py[0]);
    for (int k = 1; k < HN_MASK_SAMPLES; k++) {
        double best = -1.0, bx = 0.0, by = 0.0;
        for (int c = 0; c < 16 * k; c++) {
            double x, y, d = INFINITY;
            random_in_disk(&r, &x, &y);
            for (int i = 0; i < k; i++)
                d = vx_fmin(d, (x - px[i]) * (x - px[i]) + (y - py[i]) * (y - py[i]));
            if (d > best) {
                best = d;
                bx = x;
                by = y;
            }
        }
        px[k] = bx;
        py[k] = by;
    }
    enum { LLOYD = 16, GRID = 96 };
    for (int it = 0; it < LLOYD; it++) {
        double sx[HN_MASK_SAMPLES] = {0}, sy[HN_MASK_SAMPLES] = {0}, sn[HN_MASK_SAMPLES] = {0};
        for (int gy = 0; gy < GRID; gy++)
            for (int gx = 0; gx < GRID; gx++) {
                double x = -1.0 + (gx + 0.5) * 2.0 / GRID, y = -1.0 + (gy + 0.5) * 2.0 / GRID;
                if (x * x + y * y > 1.0)
                    continue;
                int best = 0;
                double bd = INFINITY;
                for (int s = 0; s < HN_MASK_SAMPLES; s++) {
                    double d = (x - px[s]) * (x - px[s]) + (y - py[s]) * (y - py[s]);
                    if (d < bd) {
                        bd = d;
                        best = s;
                    }
                }
                sx[best] += x;
                sy[best] += y;
                sn[best] += 1.0;
            }
        for (int s = 0; s < HN_MASK_SAMPLES; s++)
            if (sn[s] > 0.0) {
                px[s] = sx[s] / sn[s];
                py[s] = sy[s] / sn[s];
            }
    }
    for (int s = 0; s < HN_MASK_SAMPLES; s++) {
        points[s][0] = px[s];
        points[s][1] = py[s];
    }
}

typedef struct {
    double along; /* the sample's projection on the angle's direction */
    int s;
} projected;

static int by_projection(const void *a, const void *b)
{
    double x = ((const projected *)a)->along, y = ((const projected *)b)->along;
    return (x > y) - (x < y);
}

/* The table: bit s of entry (t, v) is set when sample s satisfies x cos t + y sin t <= v,
 * t = 2 pi i / 256 and v the centre of bin j of [-1, 1]. Per angle, the samples sorted by their
 * projection are swept once as v grows (each entry is the previous one plus the samples passed),
 * rather than all 128 tested per entry: the same comparisons of the same doubles, a tenth of the
 * time. */
static void build_tables(void)
{
    for (int s = 0; s < HN_MASK_SAMPLES; s++) {
        mask_samples[2 * s] = (float)hn_mask_points[s][0];
        mask_samples[2 * s + 1] = (float)hn_mask_points[s][1];
    }
    projected order[HN_MASK_SAMPLES];
    for (int ti = 0; ti < HN_TABLE_T; ti++) {
        double t = 2.0 * M_PI * ti / HN_TABLE_T, ct = cos(t), st = sin(t);
        for (int s = 0; s < HN_MASK_SAMPLES; s++) {
            order[s].along = hn_mask_points[s][0] * ct + hn_mask_points[s][1] * st;
            order[s].s = s;
        }
        qsort(order, HN_MASK_SAMPLES, sizeof *order, by_projection);
        unsigned int m[VX_MASK_WORDS] = {0};
        int passed = 0;
        for (int vi = 0; vi < HN_TABLE_V; vi++) {
            double v = -1.0 + (vi + 0.5) * 2.0 / HN_TABLE_V;
            for (; passed < HN_MASK_SAMPLES && order[passed].along <= v; passed++)
                m[order[passed].s / 32] |= 1u << (order[passed].s % 32);
            memcpy(&mask_table[((size_t)ti * HN_TABLE_V + (size_t)vi) * VX_MASK_WORDS], m, sizeof m);
        }
    }
}

const float *hn_mask_samples(void)
{
    pthread_once(&tables_once, build_tables);
    return mask_samples;
}

const unsigned int *hn_mask_table(void)
{
    pthread_once(&tables_once, build_tables);
    return mask_table;
}

/* ---- Slope variance from normals ------------------------------------------------------------ */

/* sqrt(pi) erfcx(y), double. */
static double sqrtpi_erfcx(double y)
{
    if (y < 3.0)
        return sqrt(M_PI) * exp(y * y) * erfc(y);
    /* Lentz's continued fraction; it converges faster the larger y: these term counts agree with
     * 40 terms to the last bit or two of a double (checked against mpmath's erfc at y = 3 .. 40),
     * and this function is most of the cost of heitz-neyret's level building. */
    int terms = y >= 8.0 ? 12 : y >= 5.0 ? 18 : y >= 4.0 ? 24 : 40;
    double t = 0.0;
    for (int k = terms; k >= 1; k--)
        t = (0.5 * k) / (y + t);
    return 1.0 / (y + t);
}

/* For slopes p, q ~ N(0, sigma2): over the projected area u = p^2 + q^2 ~ Exp(mean 2 sigma2), and
 * the area weighs by sqrt(1 + u), so E_area[(n.N)^2] = E[(1+u)^-1/2] / E[(1+u)^1/2] = 2 b k / (2 b + k)
 * with b = 1 / (2 sigma2) and k = E[(1+u)^-1/2] = sqrt(b) sqrt(pi) erfcx(sqrt(b)). */
double hn_m_of_sigma2(double sigma2)
{
    if (!(sigma2 > 0.0))
        return 1.0;
    double b = 1.0 / (2.0 * sigma2), k = sqrt(b) * sqrtpi_erfcx(sqrt(b));
    return 2.0 * b * k / (2.0 * b + k);
}

double hn_sigma2_of_m(double m)
{
    if (!(m < 1.0 - 1e-9))
        return 0.0;
    double lo = -30.0, hi = 12.0; /* log sigma2; m decreases with sigma2 */
    double f_hi = hn_m_of_sigma2(exp(hi)) - m;
    if (f_hi >= 0.0)
        return exp(hi);
    double f_lo = hn_m_of_sigma2(exp(lo)) - m;
    if (!(f_lo > 0.0))
        return exp(lo);
    /* Regula falsi with the Illinois halving, bracketed, to the last bits of log sigma2: about 12
     * evaluations where bisection to the same precision took 80 (this solve is most of the cost of
     * building the coarser levels, in a bake and in every frame of a moving heitz-neyret object). */
    int side = 0;
    for (int i = 0; i < 200 && hi - lo > 1e-13; i++) {
        double x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        if (!(x > lo && x < hi))
            x = 0.5 * (lo + hi);
        double f = hn_m_of_sigma2(exp(x)) - m;
        if (f == 0.0)
            return exp(x);
        if (f > 0.0) {
            lo = x, f_lo = f;
            if (side == 1)
                f_hi *= 0.5;
            side = 1;
        } else {
            hi = x, f_hi = f;
            if (side == -1)
                f_lo *= 0.5;
            side = -1;
        }
    }
    return exp(0.5 * (lo + hi));
}

/* ---- Bake: moments of the surface in a cell --------------------------------------------------- */

/* Area-weighted sums over the surface of a cell, positions relative to the cell's centre. Raw sums
 * (not central moments) so that children add up after a shift of origin. */
typedef struct {
    double w, x[3], xx[3][3], n[3], nn[3][3];
    double tang[3][3]; /* the children's in-plane spread, kept apart from xx (see derive) */
    double wf, xf[3], a[3], ax[3][3], f0, var_brdf; /* over the shaded (front) surface */
    double w2; /* sum of the squared sample weights (level 0; 0 for a child record: no noise) */
} moments;

static void moments_shift(moments *m, const double off[3])
{
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            m->xx[i][k] += m->x[i] * off[k] + off[i] * m->x[k] + m->w * off[i] * off[k];
    for (int i = 0; i < 3; i++)
        m->x[i] += m->w * off[i];
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < 3; k++)
            m->ax[c][k] += m->a[c] * off[k];
    for (int i = 0; i < 3; i++)
        m->xf[i] += m->wf * off[i];
}

static void moments_add(moments *dst, const moments *s)
{
    double *d = (double *)dst;
    const double *p = (const double *)s;
    for (size_t i = 0; i < sizeof(moments) / sizeof(double); i++)
        d[i] += p[i];
}

/* Unit eigenvector of the largest eigenvalue of a symmetric 3x3 matrix (power iteration from its
 * largest column: enough for the sheet axis of normals' second moments). */
static void principal_axis(const double m[3][3], double out[3])
{
    int best = 0;
    for (int i = 1; i < 3; i++)
        if (m[i][i] > m[best][best])
            best = i;
    double v[3] = {m[0][best], m[1][best], m[2][best]};
    for (int it = 0; it < 64; it++) {
        double w[3] = {0, 0, 0}, len = 0.0;
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                w[i] += m[i][k] * v[k];
        for (int i = 0; i < 3; i++)
            len += w[i] * w[i];
        len = sqrt(len);
        if (!(len > 1e-300))
            break;
        int same = 1;
        for (int i = 0; i < 3; i++) {
            double next = w[i] / len;
            same &= next == v[i];
            v[i] = next;
        }
        if (same) /* an exact fixed point: the remaining iterations would not change a bit */
            break;
    }
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 1e-300)) {
        out[0] = 0, out[1] = 0, out[2] = 1;
        return;
    }
    for (int i = 0; i < 3; i++)
        out[i] = v[i] / len;
}

/* Below this mean-normal length the cell's normals disagree too much for a side: a sheet seen
 * from both sides (double-sided leaves) or a closed blob smaller than the cell. */
#define HN_ONE_SIDED_MIN 0.3
/* ... and a sheet: normals along one axis (up to sign) whose mean is short against that axis,
 * |n|^2 < HN_SHEET_RATIO lambda_max(E[n n^T]). A one-sided surface has |n|^2 close to lambda_max
 * however curved (Jensen: |n|^2 <= lambda_max, equal for a plane; a box's corner 1/3 against 1/3,
 * a right-angled crease 1/2 against 1/2), a double-sided sheet hit k times from one side and
 * m - k from the other ((k - (m - k)) / m)^2 against 1. Why not |n| < 0.3 alone: the mean of m
 * random signs is 1/sqrt(m), so a leaf clipping a cell with 5 to 15 hits came out one-sided
 * about half the time (a half-space with a random side, at trees 128^3 half the leaf cells); this
 * ratio misses only a sheet hit from one side only (2^(1-m): 6 % at m = 5). */
#define HN_SHEET_RATIO 0.5

/* The centroid of the polygon where the plane x.N = h cuts the cube [-size/2, size/2]^3 (the patch
 * a surface spanning the cell would have); 0 when the plane misses the cube. */
static int plane_cube_centroid(const double N[3], double h, double size, double out[3])
{
    double pts[12][3], c[3] = {0, 0, 0};
    int np = 0;
    double half = 0.5 * size;
    for (int a = 0; a < 3; a++) { /* the 4 edges along axis a */
        int b = (a + 1) % 3, d = (a + 2) % 3;
        if (!(fabs(N[a]) > 1e-12))
            continue;
        for (int k = 0; k < 4; k++) {
            double x[3];
            x[b] = (k & 1) ? half : -half;
            x[d] = (k & 2) ? half : -half;
            x[a] = (h - N[b] * x[b] - N[d] * x[d]) / N[a];
            if (fabs(x[a]) > half)
                continue;
            for (int i = 0; i < 3; i++)
                pts[np][i] = x[i];
            np++;
        }
    }
    if (np < 3)
        return 0;
    for (int j = 0; j < np; j++)
        for (int i = 0; i < 3; i++)
            c[i] += pts[j][i] / np;
    /* Order the vertices by angle about their mean in the plane, then the fan's area centroid. */
    double t1[3], t2[3], ref[3] = {fabs(N[0]) < 0.9 ? 1.0 : 0.0, fabs(N[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    t1[0] = N[1] * ref[2] - N[2] * ref[1], t1[1] = N[2] * ref[0] - N[0] * ref[2], t1[2] = N[0] * ref[1] - N[1] * ref[0];
    double l1 = sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
    for (int i = 0; i < 3; i++)
        t1[i] /= l1;
    t2[0] = N[1] * t1[2] - N[2] * t1[1], t2[1] = N[2] * t1[0] - N[0] * t1[2], t2[2] = N[0] * t1[1] - N[1] * t1[0];
    double ang[12];
    for (int j = 0; j < np; j++) {
        double u = 0, v = 0;
        for (int i = 0; i < 3; i++) {
            u += (pts[j][i] - c[i]) * t1[i];
            v += (pts[j][i] - c[i]) * t2[i];
        }
        ang[j] = atan2(v, u);
    }
    for (int j = 1; j < np; j++) /* insertion sort: at most 12 */
        for (int k = j; k > 0 && ang[k] < ang[k - 1]; k--) {
            double t = ang[k];
            ang[k] = ang[k - 1], ang[k - 1] = t;
            for (int i = 0; i < 3; i++) {
                t = pts[k][i];
                pts[k][i] = pts[k - 1][i], pts[k - 1][i] = t;
            }
        }
    double area = 0.0, acc[3] = {0, 0, 0};
    for (int j = 0; j < np; j++) {
        const double *p0 = pts[j], *p1 = pts[(j + 1) % np];
        double e0[3] = {p0[0] - c[0], p0[1] - c[1], p0[2] - c[2]}, e1[3] = {p1[0] - c[0], p1[1] - c[1], p1[2] - c[2]};
        double cr[3] = {e0[1] * e1[2] - e0[2] * e1[1], e0[2] * e1[0] - e0[0] * e1[2], e0[0] * e1[1] - e0[1] * e1[0]};
        double ar = 0.5 * fabs(cr[0] * N[0] + cr[1] * N[1] + cr[2] * N[2]);
        area += ar;
        for (int i = 0; i < 3; i++)
            acc[i] += ar * (c[i] + p0[i] + p1[i]) / 3.0;
    }
    if (!(area > 1e-12 * size * size)) {
        for (int i = 0; i < 3; i++)
            out[i] = c[i];
        return 1;
    }
    for (int i = 0; i < 3; i++)
        out[i] = acc[i] / area;
    return 1;
}

/* The record's fields from a cell's moments (cell edge `size`). */
static void derive(const moments *m, float size, hn_data *d)
{
    memset(d, 0, sizeof *d);
    if (!(m->w > 0.0))
        return; /* area 0: the cell is ignored when interpolating */
    double mean[3], nbar[3], N[3], C[3][3], NN[3][3];
    for (int i = 0; i < 3; i++) {
        mean[i] = m->x[i] / m->w;
        nbar[i] = m->n[i] / m->w;
    }
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            C[i][k] = (m->xx[i][k] + m->tang[i][k]) / m->w - mean[i] * mean[k];
            NN[i][k] = m->nn[i][k] / m->w;
        }
    double len = sqrt(nbar[0] * nbar[0] + nbar[1] * nbar[1] + nbar[2] * nbar[2]);
    double axis[3], lambda_max = 0.0;
    principal_axis(NN, axis);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            lambda_max += axis[i] * NN[i][k] * axis[k];
    if (len >= HN_ONE_SIDED_MIN && len * len >= HN_SHEET_RATIO * lambda_max) {
        for (int i = 0; i < 3; i++)
            N[i] = nbar[i] / len;
    } else {
        for (int i = 0; i < 3; i++) /* principal_axis(NN) again, already computed */
            N[i] = axis[i];
        if (N[0] * nbar[0] + N[1] * nbar[1] + N[2] * nbar[2] < 0.0)
            for (int i = 0; i < 3; i++)
                N[i] = -N[i];
        d->two_sided = 1;
    }
    /* The plane: the least-squares fit of the positions (smallest eigenvector of their covariance)
     * when the cloud is clearly flat and the fit agrees with the normals. The sampled mean normal
     * alone wobbles by sigma_n / sqrt(hits) (several degrees with ~70 hits of a rough surface), and
     * a plane tilted by e turns the cell's width into a height variance size^2 e^2 / 12 that has
     * nothing to do with the surface's relief. */
    double ew[3], ev[3][3];
    eigen_sym3(C, ew, ev);
    int lo = 0, mid = 1;
    for (int i = 1; i < 3; i++)
        if (ew[i] < ew[lo])
            lo = i;
    for (int i = 0; i < 3; i++)
        if (i != lo && (mid == lo || ew[i] < ew[mid]))
            mid = i;
    double fit[3] = {ev[0][lo], ev[1][lo], ev[2][lo]};
    double agree = fit[0] * N[0] + fit[1] * N[1] + fit[2] * N[2];
    if (ew[lo] < 0.25 * ew[mid] && fabs(agree) > 0.7) {
        double sgn = agree < 0.0 ? -1.0 : 1.0;
        for (int i = 0; i < 3; i++)
            N[i] = sgn * fit[i];
    }
    /* Stored normal: the plane's orientation with the mean normal's length along it (how much the
     * normals agree); a two-sided sheet stores its unit axis. */
    double along = d->two_sided ? 1.0 : vx_fmax(nbar[0] * N[0] + nbar[1] * N[1] + nbar[2] * N[2], HN_ONE_SIDED_MIN);
    d->n = v3((float)(along * N[0]), (float)(along * N[1]), (float)(along * N[2]));
    double h = 0.0, var_h = 0.0, mq = 0.0, var_tilt = 0.0;
    for (int i = 0; i < 3; i++) {
        h += N[i] * mean[i];
        for (int k = 0; k < 3; k++) {
            var_h += N[i] * C[i][k] * N[k];
            mq += N[i] * NN[i][k] * N[k];
            var_tilt += N[i] * m->tang[i][k] * N[k] / m->w;
        }
    }
    var_h = vx_fmax(var_h, 0.0);
    var_tilt = vx_fmin(vx_fmax(var_tilt, 0.0), var_h);
    d->h = (float)h;
    d->var_h = (float)var_h;
    d->var_n = (float)hn_sigma2_of_m(mq);
    d->area = (float)m->w;
    /* psi (hn_record.h): where the patch ends. For a patch that fills the plane's cut of the cell
     * from one side up to a straight edge, the patch's centroid lies off the cut's centroid by
     * half the distance from the edge to the far side, so the edge lies 2 |offset| - size/2 from
     * the cut's centroid (+size/2: a sliver at the far side; -size/2: the whole cut). The cut's
     * centroid rather than the cell's centre: a tilted plane through a corner of the cell is
     * continued by the neighbours, not ended. */
    {
        double cc[3], off2 = 0.0;
        if (!plane_cube_centroid(N, h, size, cc))
            for (int i = 0; i < 3; i++)
                cc[i] = h * N[i];
        double o[3], on = 0.0;
        for (int i = 0; i < 3; i++) {
            o[i] = mean[i] - cc[i];
            on += o[i] * N[i];
        }
        for (int i = 0; i < 3; i++) {
            o[i] -= on * N[i];
            off2 += o[i] * o[i];
        }
        /* The sampled centroid wanders by the in-plane spread over the effective sample count: a
         * cell with a few hits (a plane on its face, whose hits mostly go to the neighbour) must
         * not read as an edge, so twice that standard error comes off the offset. */
        if (m->w2 > 0.0) {
            double n_eff = m->w * m->w / m->w2, spread = C[0][0] + C[1][1] + C[2][2] - var_h;
            off2 = vx_fmax(off2 - 4.0 * vx_fmax(spread, 0.0) / n_eff, 0.0);
        }
        d->psi = (float)vx_fmin(vx_fmax(2.0 * sqrt(off2) - 0.5 * size, -0.5 * size), 0.5 * size);
    }
    if (!(m->wf > 0.0))
        return; /* only back faces: colour unknown (black if no neighbour knows better) */
    d->has_color = 1;
    double sigma_h = sqrt(var_h), a[3];
    for (int c = 0; c < 3; c++)
        a[c] = vx_fmin(vx_fmax(m->a[c] / m->wf, 0.0), 1.0);
    d->a = v3((float)a[0], (float)a[1], (float)a[2]);
    /* a_s from Cov(a, h): for Gaussian heights and a = a + a_s s(h), Stein's lemma gives
     * E[h s(h)] = sigma_h / sqrt(pi), so a_s = sqrt(pi) Cov(a, h) / sigma_h exactly; unlike the
     * projection on s itself, the covariance combines exactly from children to parents. With
     * sigma_h = 0 (g a step: no depth to correlate with) a_s is 0. */
    /* A child's tilt relative to this cell's plane (its in-plane spread seen along this normal,
     * var_tilt) is height variation whose colour correlation the child's record cannot carry (it
     * keeps a_s along its own normal only). Under H5 colour follows depth at every scale, so that
     * part of the variance gets the regression slope Cov / Var of the rest; the factor is capped
     * so that a curved cell (all tilt, little else) does not amplify a chance correlation. */
    double as[3] = {0, 0, 0};
    double var_rest = var_h - var_tilt;
    double gain = var_rest > 0.0 ? vx_fmin(var_h / var_rest, 4.0) : 1.0;
    if (sigma_h > 1e-5 * size) {
        for (int c = 0; c < 3; c++) {
            double cov = 0.0;
            for (int k = 0; k < 3; k++)
                cov += N[k] * (m->ax[c][k] / m->wf - a[c] * m->xf[k] / m->wf);
            double bound = vx_fmin(a[c], 1.0 - a[c]);
            as[c] = vx_fmin(vx_fmax(sqrt(M_PI) * gain * cov / sigma_h, -bound), bound);
        }
    }
    d->as = v3((float)as[0], (float)as[1], (float)as[2]);
    d->f0 = (float)(m->f0 / m->wf);
    d->var_brdf = (float)(m->var_brdf / m->wf);
}

/* Level 0 from the shared sampler's rays. Each hit inside the voxel is weighted by the area of the
 * voxel's projection along its direction, (|dx| + |dy| + |dz|) size^2: the sampler spreads a
 * direction's rays uniformly over that projection, so a surface element dA is hit with probability
 * |n.d| dA / A_proj(d), and the weight makes the hits area-uniform (the mean of |n.d| over the
 * sphere is 1/2 for every orientation); the summed weights estimate the area, 2 sum / K. Both
 * sides' hits give positions (back hits are the same surface seen from inside; their normal, which
 * faces the ray, is turned outward); only front hits give colour and material. */
static void hn_bake(const vx_voxel *v, const vx_sample *samples, int n, void *out)
{
    moments m;
    memset(&m, 0, sizeof m);
    double c[3] = {v->lo.x + 0.5 * v->size, v->lo.y + 0.5 * v->size, v->lo.z + 0.5 * v->size};
    double unit = n > 0 ? 2.0 * (double)v->size * v->size / n : 0.0;
    for (int i = 0; i < n; i++) {
        const vx_sample *s = &samples[i];
        int front = s->kind == VX_SAMPLE_INSIDE_FRONT;
        if (!front && s->kind != VX_SAMPLE_INSIDE_BACK)
            continue;
        if (!isfinite(s->t_hit))
            continue;
        double w = unit * (fabs(s->dir.x) + fabs(s->dir.y) + fabs(s->dir.z));
        double x[3] = {s->origin.x + (double)s->dir.x * s->t_hit - c[0], s->origin.y + (double)s->dir.y * s->t_hit - c[1],
                       s->origin.z + (double)s->dir.z * s->t_hit - c[2]};
        double sign = front ? 1.0 : -1.0;
        double nv[3] = {sign * s->normal.x, sign * s->normal.y, sign * s->normal.z};
        m.w += w;
        m.w2 += w * w;
        for (int k = 0; k < 3; k++) {
            m.x[k] += w * x[k];
            m.n[k] += w * nv[k];
            for (int l = 0; l < 3; l++) {
                m.xx[k][l] += w * x[k] * x[l];
                m.nn[k][l] += w * nv[k] * nv[l];
            }
        }
        if (front) {
            double a[3] = {s->albedo.x, s->albedo.y, s->albedo.z};
            m.wf += w;
            for (int k = 0; k < 3; k++) {
                m.xf[k] += w * x[k];
                m.a[k] += w * a[k];
                for (int l = 0; l < 3; l++)
                    m.ax[k][l] += w * a[k] * x[l];
            }
            m.f0 += w * s->specular;
            m.var_brdf += w * 0.5 * (double)s->roughness * s->roughness;
        }
    }
    hn_data d;
    derive(&m, v->size, &d);
    hn_encode(&d, v->size, (hn_record *)out);
}

/* A child's record as moments about its own centre: the plane patch through c + h N with height
 * variance sigma_h^2 along N and the spread of a patch across a cube (size^2 / 12) along it; normals
 * with the stored mean and the second moment a Gaussian of slope variance sigma_n^2 has about N;
 * the colour's covariance with position along N only, sigma_h a_s / sqrt(pi) (the inverse of
 * derive's a_s). The usual statistics of the paper: means and variances combine with weights. */
static void moments_of_record(const hn_data *d, float size, moments *m)
{
    memset(m, 0, sizeof *m);
    double w = d->area;
    if (!(w > 0.0))
        return;
    double len = sqrt((double)v3_dot(d->n, d->n));
    double N[3] = {0, 0, 1};
    if (len > 1e-12) {
        N[0] = d->n.x / len;
        N[1] = d->n.y / len;
        N[2] = d->n.z / len;
    }
    double mean[3] = {d->h * N[0], d->h * N[1], d->h * N[2]};
    double tang = (double)size * size / 12.0, mq = hn_m_of_sigma2(d->var_n);
    double nbar[3] = {0, 0, 0};
    if (!d->two_sided)
        for (int i = 0; i < 3; i++)
            nbar[i] = (double)v3_get(d->n, i);
    double sigma_h = sqrt(vx_fmax(d->var_h, 0.0f));
    double a[3] = {d->a.x, d->a.y, d->a.z}, as[3] = {d->as.x, d->as.y, d->as.z};
    m->w = w;
    m->wf = d->has_color ? w : 0.0;
    for (int i = 0; i < 3; i++) {
        m->x[i] = w * mean[i];
        m->xf[i] = m->wf * mean[i];
        m->n[i] = w * nbar[i];
        m->a[i] = m->wf * a[i];
        for (int k = 0; k < 3; k++) {
            double delta = i == k ? 1.0 : 0.0, nn = N[i] * N[k];
            m->xx[i][k] = w * (d->var_h * nn + mean[i] * mean[k]);
            m->tang[i][k] = w * tang * (delta - nn);
            m->nn[i][k] = w * (mq * nn + 0.5 * (1.0 - mq) * (delta - nn));
        }
    }
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < 3; k++)
            m->ax[c][k] = m->wf * (a[c] * mean[k] + sigma_h * as[c] / sqrt(M_PI) * N[k]);
    m->f0 = m->wf * d->f0;
    m->var_brdf = m->wf * d->var_brdf;
}

/* A child sees the edge (it is cut by it) when |psi| < edge_clear size: clear of the saturated
 * values +-size/2 by more than a covered child's sampled psi wanders. The model's parameter
 * `edge_clear` (0 turns the correction below off). */
#define HN_EDGE_CLEAR_DEFAULT 0.4
/* ... and only where the children's psi rise across the parent as a distance does: the fitted slope
 * along the edge's normal at least this (a distance field's is 1; a straight edge across the
 * children, saturation and all, gives 0.5 - 0.7; fully covered children's scatter 0 - 0.2). Below
 * it the "edge" is the sampled psi's noise and its direction arbitrary. Why 0.1: at 0 or 0.05 a
 * 20-degree plate (160^3, 64^2) kept two pixels of holes (coverage 0.62 / 0.56); at 0.3 trees'
 * MSE at 128^3 rose 3 %. */
#define HN_EDGE_MIN_SLOPE 0.1f

/* A coarser cell's psi from its children's, where a child sees the edge (its psi is not
 * saturated): each such child predicts the in-plane distance from the parent's centre to the edge
 * as its own psi plus the in-plane offset between the centres along the edge's normal u, and the
 * predictions are averaged by area; u points up the children's psi (from the covered children to
 * the empty ones the plane runs through, which count +size/2 as in hn_blend_edge). Why: the
 * moments place each child's patch at its centre's foot, and a child cut by the edge holds its
 * patch off-centre, toward the inside: the parent's centroid, and so its edge, moved outward by
 * up to about an eighth of the parent. The cone reads these levels at about a pixel per cell, so
 * that was a silhouette bias that stopped shrinking with the voxel (a plate's edge, 64^2 image:
 * +0.19 px at 256^3, now +0.02 px; MSE at 128^3, 128^2 against a 256-spp truth: trees 3.9e-3 ->
 * 2.5e-3, island 9.2e-3 -> 9.0e-3, city 3.8e-3 -> 3.7e-3, bunny 4.9e-4 -> 4.8e-4). Without an
 * edge child (the edge runs along children's faces, or there is none) the moments are exact and
 * stay. */
static void parent_edge_from_children(const hn_data kids[8], float child, float size, float edge_clear, hn_data *d)
{
    /* Only where the moments see an edge too: a plate on cell faces leaves its children a few
     * hits each, whose psi wanders off saturation without any edge (and made holes). */
    if (!(d->area > 0.0f) || !(d->psi > -0.45f * size))
        return;
    vec3 N = v3_normalize_or(d->n, v3(0.0f, 0.0f, 1.0f));
    /* The occupied children and the empty ones the plane reaches (the half-sum of |N|'s components,
     * each at least 0.05, from their centres), their psi (an empty child: +child/2, the surface
     * ended), and the in-plane
     * direction u up which they rise: the least-squares gradient about their means. Why about the
     * means: the plane runs through only some of the children, and the uncentred sum of centre x
     * psi pointed from those children's centres' mean toward the others, whatever the psi: with
     * every child's psi about -child/2 (no edge), a sliver child's wandering psi, predicted from
     * 0.6 child away along that arbitrary u, made an interior parent's psi +0.34 of its size, and
     * the element's mask opened a hole (a 20-degree plate, 64^2: least interior coverage 0.83 /
     * 0.60 / 0.36 at 96 / 128 / 160^3, now 0.99 at each). The children count alike: weighting
     * them by how much of each the plane cuts cost bunny / trees 1.2 % / 0.8 % of MSE at 128^3.
     * An occupied child counts even where the parent's plane misses it: a moved record's split8
     * pieces hold their own planes, and leaving them out raised heitz-neyret's split8 error on
     * tests/test_dynamic.py's frame 4 from 4.3x to 5.4x the re-bake's (now 4.6x). */
    float cut[8], psi[8], sum_cut = 0.0f, mean_psi = 0.0f;
    vec3 centre[8], mean_c = v3(0.0f, 0.0f, 0.0f);
    float support = 0.5f * (vx_fmaxf(fabsf(N.x), 0.05f) + vx_fmaxf(fabsf(N.y), 0.05f) + vx_fmaxf(fabsf(N.z), 0.05f));
    int any_edge = 0;
    for (int k = 0; k < 8; k++) {
        centre[k] = v3((float)(((k >> 2) - 0.5) * child), (float)((((k >> 1) & 1) - 0.5) * child),
                       (float)(((k & 1) - 0.5) * child));
        cut[k] = kids[k].area > 0.0f || fabsf(v3_dot(N, centre[k]) - d->h) < support * child ? 1.0f : 0.0f;
        psi[k] = kids[k].area > 0.0f ? kids[k].psi : 0.5f * child;
        any_edge |= kids[k].area > 0.0f && fabsf(psi[k]) < edge_clear * child && cut[k] > 0.0f;
        sum_cut += cut[k];
        mean_psi += cut[k] * psi[k];
        mean_c = v3_madd(mean_c, centre[k], cut[k]);
    }
    if (!any_edge || !(sum_cut > 0.0f))
        return;
    mean_psi /= sum_cut;
    mean_c = v3_scale(mean_c, 1.0f / sum_cut);
    vec3 grad = v3(0.0f, 0.0f, 0.0f);
    for (int k = 0; k < 8; k++)
        grad = v3_madd(grad, v3_sub(centre[k], mean_c), cut[k] * (psi[k] - mean_psi));
    grad = v3_madd(grad, N, -v3_dot(grad, N));
    float gl = sqrtf(v3_dot(grad, grad));
    if (!(gl > 1e-12f * child))
        return;
    vec3 u = v3_scale(grad, 1.0f / gl);
    float var_u = 0.0f;
    for (int k = 0; k < 8; k++) {
        float o = v3_dot(u, v3_sub(centre[k], mean_c));
        var_u += cut[k] * o * o;
    }
    if (!(gl >= HN_EDGE_MIN_SLOPE * var_u))
        return; /* slope gl / var_u along u */
    double sw = 0.0, sp = 0.0;
    for (int k = 0; k < 8; k++) {
        if (!(kids[k].area > 0.0f) || !(fabsf(kids[k].psi) < edge_clear * child) || !(cut[k] > 0.0f))
            continue;
        sw += kids[k].area;
        sp += kids[k].area * (kids[k].psi - v3_dot(u, centre[k]));
    }
    d->psi = (float)vx_fmin(vx_fmax(sp / sw, -0.5 * size), 0.5 * size);
}

/* Coarser levels, each cell from its (up to 8) children. */
static int hn_bake_finish(const voxel_grid *g, void *records, const struct vx_bake_params *p)
{
    hn_record *rec = records;
    float edge_clear = (float)p->value[0]; /* hn_params[0] */
    for (int l = 1; l < g->levels; l++) {
        size_t off = bake_level_offset(g, l), child_off = bake_level_offset(g, l - 1);
        float size = (float)ldexp(g->voxel_size_d, l), child = (float)ldexp(g->voxel_size_d, l - 1);
        size_t count = grid_count(g, l);
        for (size_t i = 0; i < count; i++) {
            int x, y, z;
            grid_coords(g, l, i, &x, &y, &z);
            moments sum;
            memset(&sum, 0, sizeof sum);
            hn_data kids[8];
            for (int k = 0; k < 8; k++) {
                int dx = k >> 2, dy = (k >> 1) & 1, dz = k & 1;
                int64_t ci = grid_index(g, l - 1, 2 * x + dx, 2 * y + dy, 2 * z + dz);
                kids[k].area = 0.0f;
                if (ci < 0)
                    continue;
                hn_decode(&rec[child_off + (size_t)ci], child, &kids[k]);
                moments m;
                moments_of_record(&kids[k], child, &m);
                double shift[3] = {(dx - 0.5) * child, (dy - 0.5) * child, (dz - 0.5) * child};
                moments_shift(&m, shift);
                moments_add(&sum, &m);
            }
            hn_data d;
            derive(&sum, size, &d);
            parent_edge_from_children(kids, child, size, edge_clear, &d);
            hn_encode(&d, size, &rec[off + i]);
        }
    }
    return 0;
}

/* ---- Moving records (issue 17; vx_model.transform and .combine) -------------------------------- */

/* Rotation about the cell's centre: the mean normal turns; h (a distance along it from the centre),
 * the variances, the area, psi (an in-plane distance) and the colour statistics are invariant. */
static void hn_transform(const void *in, const float R[9], void *out)
{
    hn_record r = *(const hn_record *)in;
    static const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (memcmp(R, I, sizeof I) != 0) {
        float n[3] = {(float)r.n[0] / 32767.0f, (float)r.n[1] / 32767.0f, (float)r.n[2] / 32767.0f};
        for (int i = 0; i < 3; i++)
            r.n[i] = hn_snorm16(R[3 * i] * n[0] + R[3 * i + 1] * n[1] + R[3 * i + 2] * n[2]);
    }
    *(hn_record *)out = r;
}

/* Parts in one cell (several; one part alone keeps its statistics, below): the same sums of
 * moments the coarser levels are built from (hn_bake_finish),
 * each part's moments taken about its own (moved) centre, shifted to the cell's centre by its
 * offset and scaled by the fraction it covers; so a plane keeps its position when nearest
 * rounds its record into a neighbouring cell, and split8's pieces each hold the plane where it
 * lies. psi (where the patch ends) does not survive the sums (moments_of_record centres each
 * patch): it is the parts' area-weighted mean. */
static void hn_combine(const vx_record_part *parts, int n, float voxel_size, void *out)
{
    const vx_record_part *p0 = &parts[0];
    if (n == 1 && p0->weight == 1.0f && p0->offset[0] == 0.0f && p0->offset[1] == 0.0f && p0->offset[2] == 0.0f) {
        *(hn_record *)out = *(const hn_record *)p0->record;
        return;
    }
    if (n == 1) {
        /* One part: its statistics as they are, the plane's height taken to the cell's centre and
         * the area to the fraction covered (what the sums below give, without their round trip
         * through a re-fit, which costs as much as the bake's own per-voxel work). */
        hn_record r = *(const hn_record *)p0->record;
        vec3 N = v3_normalize_or(v3((float)r.n[0], (float)r.n[1], (float)r.n[2]), v3(0.0f, 0.0f, 1.0f));
        r.h += voxel_size * (N.x * p0->offset[0] + N.y * p0->offset[1] + N.z * p0->offset[2]);
        if (p0->weight != 1.0f)
            r.area = hn_float_to_half(hn_half_to_float(r.area) * p0->weight);
        *(hn_record *)out = r;
        return;
    }
    moments sum;
    memset(&sum, 0, sizeof sum);
    double psi = 0.0, psi_w = 0.0;
    for (int i = 0; i < n; i++) {
        hn_data d;
        hn_decode(parts[i].record, voxel_size, &d);
        moments m;
        moments_of_record(&d, voxel_size, &m);
        double shift[3] = {(double)parts[i].offset[0] * voxel_size, (double)parts[i].offset[1] * voxel_size,
                           (double)parts[i].offset[2] * voxel_size};
        moments_shift(&m, shift);
        double *v = (double *)&m;
        for (size_t k = 0; k < sizeof(moments) / sizeof(double); k++)
            v[k] *= parts[i].weight;
        moments_add(&sum, &m);
        psi += m.w * d.psi;
        psi_w += m.w;
    }
    hn_data d;
    derive(&sum, voxel_size, &d);
    if (psi_w > 0.0)
        d.psi = (float)(psi / psi_w);
    hn_encode(&d, voxel_size, (hn_record *)out);
}

/* ---- The model ---------------------------------------------------------------------------------- */

static const void *hn_table(size_t *bytes)
{
    *bytes = HN_TABLE_WORDS * sizeof(unsigned int);
    return hn_mask_table();
}

static const vx_param hn_params[] = {
    {"edge_clear", HN_EDGE_CLEAR_DEFAULT, 0.0, 0.5,
     "coarser levels: a child whose |psi| < edge_clear x its size sees the edge (0: the moments' edge alone)",
     .is_switch = 0},
    {0},
};

static const vx_cone_eval hn_eval = {
    .source = "hn_cone.h",
    .element = VX_PORTABLE(hn_cone_element_eval),
    .table = hn_table,
};

const vx_model model_heitz_neyret = {
    .abi_version = VX_MODEL_ABI_VERSION,
    .name = "heitz-neyret",
    .description = "Heitz & Neyret 2012: mean plane, height and slope variances, colour vs depth per cell of every "
                   "MIP level; cone marching with 128-sample coverage masks",
    .record = {.bytes = sizeof(hn_record), .layout_version = 2, .levels = 1},
    .params = hn_params,
    .bake_voxel = hn_bake,
    .bake_finish = hn_bake_finish,
    .validate_record = hn_validate_record,
    .cone = &hn_eval,
    .transform = hn_transform,
    .combine = hn_combine,
};
