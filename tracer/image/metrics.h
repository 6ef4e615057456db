/* Image error metrics, defined exactly as scikit-image's (see metrics.c). */
#ifndef VX_METRICS_H
#define VX_METRICS_H

#include "image.h"

typedef struct {
    double mse;  /* mean over every pixel and colour channel of (a - b)^2 */
    double psnr; /* 10 log10(1 / mse) for data range 1; +inf when mse == 0 */
    double ssim; /* mean SSIM (Wang et al. 2004), RGB = mean of the channel SSIMs */
} image_metrics;

#ifdef __cplusplus
extern "C" {
#endif

/* Images of different sizes or channel counts are an error, and so are images smaller than 11x11
 * (SSIM's window; scikit-image raises too), and so is an image with a NaN or infinite colour value.
 * With 2 or 4 channels the last one (alpha) is ignored: only colour channels count, in MSE, SSIM and
 * the heat map. */
int metrics_compare(const image *a, const image *b, image_metrics *out, vx_err *e);

/* SSIM of one channel of a and b, skimage's structural_similarity(gaussian_weights=True,
 * sigma=1.5, use_sample_covariance=False, data_range=1). NaN when the images differ in size or are
 * smaller than 11x11, or channel is out of range. */
double metrics_ssim_channel(const image *a, const image *b, int channel);

/* Per-pixel error heat map (RGB, for viewing): mean absolute error over colour channels mapped to a
 * colour ramp scaled so the largest error is its top (pale yellow) and zero error is black. */
int metrics_heatmap(const image *a, const image *b, image *out, vx_err *e);

#ifdef __cplusplus
}
#endif

#endif
