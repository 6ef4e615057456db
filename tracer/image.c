/* Image buffers, the write dispatcher, the sRGB PNG encoder and the temp-then-rename helpers that
 * make every writer atomic (a crash or error never leaves a truncated image under the real name). */
#include "image.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdatomic.h>
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
    img->data = calloc(n, sizeof(float));
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

/* The extension after the last '.' of the file name (not of a directory), or "" when there is none. */
static const char *extension(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash + 1 : path, '.');
    return dot ? dot : "";
}

int image_write(const image *img, const char *path, vx_err *e)
{
    const char *ext = extension(path);
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
    int rc = image_tmp_create(path, tmp, sizeof tmp, e);
    if (rc == 0) {
        rc = image_write_png8_oiio(px, img->width, img->height, c, tmp, path, e);
        if (rc == 0)
            rc = image_tmp_commit(tmp, path, e);
        else
            unlink(tmp);
    }
    free(px);
    return rc;
}

int image_tmp_create(const char *path, char *tmp, size_t tmp_size, vx_err *e)
{
    /* pid + counter keeps concurrent writers (other processes, other threads) off each other's files. */
    static atomic_uint counter;
    unsigned n = atomic_fetch_add(&counter, 1u);
    int len = snprintf(tmp, tmp_size, "%s.tmp.%ld.%u", path, (long)getpid(), n);
    if (len < 0 || (size_t)len >= tmp_size)
        return vx_fail(e, "%s: path too long", path);
    /* O_EXCL: never clobber a file we did not create; creating it here (rather than letting the
     * format library do it) gives us errno, hence a precise message for unwritable directories. */
    int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        int err = errno;
        const char *slash = strrchr(path, '/');
        const char *dir = ".";
        int dirlen = 1;
        if (slash) {
            dir = slash == path ? "/" : path;
            dirlen = slash == path ? 1 : (int)(slash - path);
        }
        return vx_fail(e, "cannot write %s: cannot create a file in directory '%.*s': %s", path, dirlen, dir,
                       strerror(err));
    }
    close(fd);
    return 0;
}

int image_tmp_commit(const char *tmp, const char *path, vx_err *e)
{
    if (rename(tmp, path) != 0) {
        int err = errno;
        unlink(tmp);
        return vx_fail(e, "cannot write %s: rename from %s failed: %s", path, tmp, strerror(err));
    }
    return 0;
}
