/* MSE, PSNR and SSIM defined exactly as scikit-image 0.19 computes them, so numbers from voxlab and
 * from a Python notebook agree to rounding. The SSIM reference is
 *   skimage.metrics.structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
 *       use_sample_covariance=False, data_range=1, channel_axis=-1 for RGB)
 * on float64 data, i.e. (see skimage/metrics/_structural_similarity.py, scipy.ndimage):
 *   - each local statistic is scipy.ndimage.gaussian_filter(sigma=1.5, truncate=3.5, mode='reflect'):
 *     radius int(3.5*1.5+0.5) = 5, 11 taps exp(-x^2/(2 sigma^2)) normalised by their sum, applied
 *     separably, axis 0 (down the columns) first, then axis 1, in double;
 *   - ux, uy, uxx, uyy, uxy are the filtered a, b, a*a, b*b, a*b; vx = uxx - ux^2, vy, vxy likewise;
 *   - S = (2 ux uy + C1)(2 vxy + C2) / ((ux^2 + uy^2 + C1)(vx + vy + C2)), C1 = 0.01^2, C2 = 0.03^2;
 *   - SSIM = mean of S with a border of 5 pixels cropped; RGB = mean of the per-channel values;
 *   - images narrower or shorter than the 11-pixel window are an error (skimage raises).
 * The crop removes exactly the pixels whose window reaches past the border, so the 'reflect' padding
 * never reaches the mean: we evaluate only interior pixels, row by row, in O(width) memory.
 * Floating-point operations are ordered as scipy's symmetric correlate1d and numpy's pairwise sum
 * order them, so results agree with skimage to ~1e-16. The one known gap: on AVX-512 CPUs numpy's
 * exp differs from libm's by one ulp in two of the 11 weights, which moves SSIM by up to ~1e-14.
 * (Give skimage float64 input: with float32 it computes in float32, ~1e-7 away from either.)
 *
 * Alpha is not colour: with 2 (grey+alpha) or 4 (RGBA) channels the last one is ignored by every
 * metric here (MSE, SSIM and the heat map), so images rendered with and without coverage compare. */
#include "metrics.h"

#include <math.h>
#include <stdlib.h>

#define SSIM_RADIUS 5 /* int(truncate * sigma + 0.5) with truncate 3.5, sigma 1.5 */
#define SSIM_WIN (2 * SSIM_RADIUS + 1)

static int colour_channels(int channels)
{
    return channels == 2 || channels == 4 ? channels - 1 : channels;
}

/* numpy's pairwise summation (npy_pairwise_sum): blocks of 8 partial sums, split above 128. */
static double pairwise_sum(const double *a, size_t n)
{
    if (n < 8) {
        double res = 0.0;
        for (size_t i = 0; i < n; i++)
            res += a[i];
        return res;
    }
    if (n <= 128) {
        double r[8];
        size_t i;
        for (int j = 0; j < 8; j++)
            r[j] = a[j];
        for (i = 8; i < n - (n % 8); i += 8)
            for (int j = 0; j < 8; j++)
                r[j] += a[i + j];
        double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++)
            res += a[i];
        return res;
    }
    size_t n2 = n / 2;
    n2 -= n2 % 8;
    return pairwise_sum(a, n2) + pairwise_sum(a + n2, n - n2);
}

/* scipy's _gaussian_kernel1d: w[k] is the weight at offset +-k. */
static void gaussian_weights(double w[SSIM_RADIUS + 1])
{
    const double sigma = 1.5, sigma2 = sigma * sigma;
    double phi[SSIM_WIN];
    for (int i = 0; i < SSIM_WIN; i++) {
        int x = i - SSIM_RADIUS;
        phi[i] = exp(-0.5 / sigma2 * (double)(x * x));
    }
    double sum = pairwise_sum(phi, SSIM_WIN);
    for (int k = 0; k <= SSIM_RADIUS; k++)
        w[k] = phi[SSIM_RADIUS + k] / sum;
}

enum { QX, QY, QXX, QYY, QXY, NQ }; /* the five filtered statistics */

/* Mean SSIM of one channel; 0 on success, -1 when out of memory. Sizes are checked by the callers. */
static int ssim_channel(const image *a, const image *b, int ch, double *out)
{
    const int w = a->width, h = a->height, nc = a->channels, r = SSIM_RADIUS;
    double wt[SSIM_RADIUS + 1];
    gaussian_weights(wt);
    const double C1 = pow(0.01 * 1.0, 2), C2 = pow(0.03 * 1.0, 2); /* (K * data_range)^2 as skimage */

    double *vert = malloc(sizeof(double) * NQ * (size_t)w); /* vertical pass of the current row */
    double *srow = malloc(sizeof(double) * (size_t)(w - 2 * r));
    if (!vert || !srow) {
        free(vert);
        free(srow);
        return -1;
    }
    double total = 0.0;
    for (int y = r; y < h - r; y++) {
        /* Axis 0: for every column, the 11 rows around y (all inside the image for cropped rows). */
        for (int x = 0; x < w; x++) {
            /* scipy's symmetric correlate1d: centre * w0 first, then the pairs from the outside in. */
            size_t ic = ((size_t)y * w + x) * nc + ch;
            double xc = a->data[ic], yc = b->data[ic];
            double s[NQ] = {xc * wt[0], yc * wt[0], (xc * xc) * wt[0], (yc * yc) * wt[0], (xc * yc) * wt[0]};
            for (int k = r; k >= 1; k--) {
                size_t i0 = ((size_t)(y - k) * w + x) * nc + ch, i1 = ((size_t)(y + k) * w + x) * nc + ch;
                double x0 = a->data[i0], x1 = a->data[i1], y0 = b->data[i0], y1 = b->data[i1];
                s[QX] += (x0 + x1) * wt[k];
                s[QY] += (y0 + y1) * wt[k];
                s[QXX] += (x0 * x0 + x1 * x1) * wt[k];
                s[QYY] += (y0 * y0 + y1 * y1) * wt[k];
                s[QXY] += (x0 * y0 + x1 * y1) * wt[k];
            }
            for (int q = 0; q < NQ; q++)
                vert[(size_t)q * w + x] = s[q];
        }
        /* Axis 1 on the cropped columns, then S as skimage writes it. */
        for (int x = r; x < w - r; x++) {
            double u[NQ];
            for (int q = 0; q < NQ; q++) {
                const double *line = vert + (size_t)q * w;
                double acc = line[x] * wt[0];
                for (int k = r; k >= 1; k--)
                    acc += (line[x - k] + line[x + k]) * wt[k];
                u[q] = acc;
            }
            double vx = u[QXX] - u[QX] * u[QX];
            double vy = u[QYY] - u[QY] * u[QY];
            double vxy = u[QXY] - u[QX] * u[QY];
            double A1 = 2 * u[QX] * u[QY] + C1, A2 = 2 * vxy + C2;
            double B1 = u[QX] * u[QX] + u[QY] * u[QY] + C1, B2 = vx + vy + C2;
            srow[x - r] = (A1 * A2) / (B1 * B2);
        }
        total += pairwise_sum(srow, (size_t)(w - 2 * r));
    }
    *out = total / ((double)(w - 2 * r) * (double)(h - 2 * r));
    free(vert);
    free(srow);
    return 0;
}

double metrics_ssim_channel(const image *a, const image *b, int channel)
{
    if (!a || !b || !a->data || !b->data || a->width != b->width || a->height != b->height ||
        a->channels != b->channels || channel < 0 || channel >= a->channels || a->width < SSIM_WIN ||
        a->height < SSIM_WIN)
        return NAN;
    double s;
    return ssim_channel(a, b, channel, &s) == 0 ? s : NAN;
}

static int check_same(const image *a, const image *b, vx_err *e)
{
    if (!a || !b || !a->data || !b->data)
        return vx_fail(e, "cannot compare an empty image");
    if (a->width != b->width || a->height != b->height || a->channels != b->channels)
        return vx_fail(e, "image sizes differ: %dx%d with %d channels vs %dx%d with %d channels", a->width,
                       a->height, a->channels, b->width, b->height, b->channels);
    return 0;
}

/* Refuses an image with a NaN or infinite colour value, naming which image, how many and the first
 * (row by row). Why: the metrics of such an image are NaN, which JSON writes as null, and the
 * experiments' tables showed a model that had made NaNs as "–", as if its row were missing. A model
 * that makes them has a defect to be seen, and its first bad pixel is named. */
static int check_finite(const image *img, const char *which, vx_err *e)
{
    const int cc = colour_channels(img->channels);
    size_t bad = 0, first = 0;
    for (size_t p = 0, n = (size_t)img->width * (size_t)img->height; p < n; p++)
        for (int c = 0; c < cc; c++)
            if (!isfinite(img->data[p * (size_t)img->channels + (size_t)c]) && bad++ == 0)
                first = p;
    if (bad)
        return vx_fail(e, "%s image has %zu NaN or infinite colour value%s (the first at pixel x=%zu, y=%zu): its "
                       "MSE and SSIM are undefined",
                       which, bad, bad == 1 ? "" : "s", first % (size_t)img->width, first / (size_t)img->width);
    return 0;
}

int metrics_compare(const image *a, const image *b, image_metrics *out, vx_err *e)
{
    if (check_same(a, b, e) != 0)
        return -1;
    const int w = a->width, h = a->height, nc = a->channels, cc = colour_channels(nc);
    if (w < SSIM_WIN || h < SSIM_WIN)
        return vx_fail(e, "image is %dx%d but SSIM needs at least %dx%d pixels (its Gaussian window, as in "
                       "scikit-image)", w, h, SSIM_WIN, SSIM_WIN);
    if (check_finite(a, "the first", e) || check_finite(b, "the second", e))
        return -1;

    /* MSE over pixels and colour channels, summed per row as numpy would, in double. */
    double *row = malloc(sizeof(double) * (size_t)w * cc);
    if (!row)
        return vx_fail(e, "out of memory comparing %dx%d images", w, h);
    double sse = 0.0;
    for (int y = 0; y < h; y++) {
        size_t n = 0;
        for (int x = 0; x < w; x++)
            for (int c = 0; c < cc; c++) {
                size_t i = ((size_t)y * w + x) * nc + c;
                double d = (double)a->data[i] - (double)b->data[i];
                row[n++] = d * d;
            }
        sse += pairwise_sum(row, n);
    }
    free(row);
    out->mse = sse / ((double)w * h * cc);
    out->psnr = out->mse == 0.0 ? INFINITY : 10.0 * log10(1.0 / out->mse);

    double s[4], ssum = 0.0;
    for (int c = 0; c < cc; c++) {
        if (ssim_channel(a, b, c, &s[c]) != 0)
            return vx_fail(e, "out of memory computing SSIM of %dx%d images", w, h);
        ssum += s[c];
    }
    out->ssim = ssum / cc;
    return 0;
}

/* Heat-map ramp, defined in display (sRGB) values so that the PNG shows these exact colours after
 * image_write_png's encoding: black (no error), purple, red, orange, pale yellow (the maximum). */
static const double ramp[][3] = {
    {0.00, 0.00, 0.00}, {0.30, 0.05, 0.55}, {0.85, 0.15, 0.30}, {1.00, 0.60, 0.05}, {1.00, 1.00, 0.85},
};

static double srgb_to_linear(double s)
{
    return s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4);
}

int metrics_heatmap(const image *a, const image *b, image *out, vx_err *e)
{
    if (check_same(a, b, e) != 0)
        return -1;
    const int w = a->width, h = a->height, nc = a->channels, cc = colour_channels(nc);
    if (image_alloc(out, w, h, 3, e) != 0)
        return -1;
    /* First pass: per-pixel mean absolute error (kept in out's red channel) and its finite maximum. */
    double maxerr = 0.0;
    for (size_t p = 0; p < (size_t)w * h; p++) {
        double m = 0.0;
        for (int c = 0; c < cc; c++)
            m += fabs((double)a->data[p * nc + c] - (double)b->data[p * nc + c]);
        m /= cc;
        out->data[p * 3] = (float)m;
        if (isfinite(m) && m > maxerr)
            maxerr = m;
    }
    const int segments = (int)(sizeof ramp / sizeof ramp[0]) - 1;
    for (size_t p = 0; p < (size_t)w * h; p++) {
        double m = out->data[p * 3];
        /* Non-finite errors (NaN/inf pixels) are the worst possible: top of the ramp. */
        double t = !isfinite(m) ? 1.0 : maxerr > 0.0 ? m / maxerr : 0.0;
        if (t > 1.0)
            t = 1.0;
        double f = t * segments;
        int i = (int)f;
        if (i >= segments)
            i = segments - 1;
        f -= i;
        for (int c = 0; c < 3; c++)
            out->data[p * 3 + c] = (float)srgb_to_linear(ramp[i][c] + (ramp[i + 1][c] - ramp[i][c]) * f);
    }
    return 0;
}
