/* Image buffers, the write dispatcher, the sRGB PNG encoder and the temp-then-rename helpers that
 * make every writer atomic (a crash or error never leaves a truncated image under the real name). */
#include "image.h"

#include "fileio.h"
#include "prefault.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

int image_alloc(image *img, int width, int height, int channels, vx_err *e)
{
    memset(img, 0, sizeof *img);
    if (width <= 0 || height <= 0 || channels < 1 || channels > 4)
        return vx_fail(e, "image_alloc: invalid image %dx%d with %d channels (expected positive size, 1-4 channels)",
                       width, height, channels);
    /* Guard the size product: a corrupt header must not turn into a small allocation. */
    size_t n = (size_t)width * (size_t)height * (size_t)channels;
    if (n / (size_t)width / (size_t)height != (size_t)channels || n > SIZE_MAX / sizeof(float))
        return vx_fail(e, "image_alloc: image %dx%d with %d channels is too large", width, height, channels);
    /* Zeroed and touched here (prefault.h): the renderers write every pixel inside their frames'
     * clocks, and a fresh page's faults belong outside them, the voxel render's and the truth's alike
     * (each had touched it itself, with the same memset). */
    img->data = vx_alloc_touched(n * sizeof(float), 0);
    if (!img->data)
        return vx_fail(e, "image_alloc: out of memory for a %dx%d image with %d channels", width, height,
                       channels);
    img->width = width;
    img->height = height;
    img->channels = channels;
    return 0;
}

void image_free(image *img)
{
    if (!img)
        return;
    free(img->data);
    memset(img, 0, sizeof *img);
}

int image_check_output(const char *path, vx_err *e)
{
    const char *ext = fileio_extension(path);
    if (fileio_check_writable(path, e)) /* first: a directory is named as one, not as an extension */
        return -1;
    if (strcasecmp(ext, ".exr") != 0 && strcasecmp(ext, ".png") != 0)
        return vx_fail(e, "%s: unsupported image extension '%s' (expected .exr or .png)", path, ext);
    return 0;
}

int image_write(const image *img, const char *path, vx_err *e)
{
    const char *ext = fileio_extension(path);
    if (strcasecmp(ext, ".exr") == 0)
        return image_write_exr(img, path, e);
    if (strcasecmp(ext, ".png") == 0)
        return image_write_png(img, path, e);
    return vx_fail(e, "%s: unsupported image extension '%s' (expected .exr or .png)", path, ext);
}

unsigned char image_linear_to_srgb8(float linear)
{
    /* Computed in double so that the 8-bit rounding of the boundary values is not at the mercy of
     * float error; !(x > 0) also catches NaN, which has no meaningful colour. */
    double x = linear;
    if (!(x > 0.0))
        return 0;
    if (x >= 1.0)
        return 255;
    double s = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    return (unsigned char)floor(s * 255.0 + 0.5);
}

/* Alpha is coverage, not light: it is quantised linearly, never gamma-encoded. */
static unsigned char linear8(float v)
{
    if (!(v > 0.0f))
        return 0;
    if (v >= 1.0f)
        return 255;
    return (unsigned char)floor((double)v * 255.0 + 0.5);
}

int image_write_png(const image *img, const char *path, vx_err *e)
{
    if (!img || !img->data || img->channels < 1 || img->channels > 4)
        return vx_fail(e, "%s: cannot write an empty image or one with %d channels as PNG (expected 1-4)", path,
                       img ? img->channels : 0);
    int c = img->channels;
    int has_alpha = c == 2 || c == 4;
    size_t n = (size_t)img->width * img->height * c;
    unsigned char *px = malloc(n);
    if (!px)
        return vx_fail(e, "%s: out of memory encoding a %dx%d PNG", path, img->width, img->height);
    for (size_t i = 0; i < n; i++) {
        int is_alpha = has_alpha && (int)(i % c) == c - 1;
        px[i] = is_alpha ? linear8(img->data[i]) : image_linear_to_srgb8(img->data[i]);
    }
    char tmp[4096];
    int rc = fileio_temp_create(path, tmp, sizeof tmp, e);
    if (rc == 0) {
        rc = image_write_png8_oiio(px, img->width, img->height, c, tmp, path, e);
        if (rc == 0)
            rc = fileio_temp_commit(tmp, path, e);
        else
            fileio_temp_discard(tmp);
    }
    free(px);
    return rc;
}

