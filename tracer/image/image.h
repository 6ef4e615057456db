/* A linear float image, channels interleaved (1 = grey, 2 = grey+alpha, 3 = RGB, 4 = RGBA), row 0 at the top. */
#ifndef VX_IMAGE_H
#define VX_IMAGE_H

#include "error.h"
#include "image_meta.h"

typedef struct {
    int width, height, channels;
    float *data;             /* width * height * channels floats */
    const image_meta *meta;  /* provenance written with an EXR (NULL: none; not owned) */
    int stored_8bit;         /* image_read: the file holds 8-bit unsigned samples (0 for images made here) */
} image;

#ifdef __cplusplus
extern "C" {
#endif

int image_alloc(image *img, int width, int height, int channels, vx_err *e);
void image_free(image *img);

/* Writes by extension: .exr = linear 32-bit float EXR (OpenEXR C API), .png = sRGB-encoded 8-bit
 * (alpha, the last of 2 or 4 channels, stored linearly); anything else is an error.
 * Writes to a temporary name in the same directory and renames, so a failure never leaves a partial file. */
int image_write(const image *img, const char *path, vx_err *e);
int image_write_exr(const image *img, const char *path, vx_err *e);
/* Whether image_write could write path (supported extension, not a directory, a writable folder),
 * checked before any work so that a bad -o fails at once rather than after the render. */
int image_check_output(const char *path, vx_err *e);
int image_write_png(const image *img, const char *path, vx_err *e);

/* Largest image read (compare's inputs, textures): 64 Mpixels, 1 GiB as RGBA floats. A small
 * compressed file can declare a huge image; it is refused before anything is allocated. */
#define IMAGE_MAX_PIXELS (64LL * 1024 * 1024)

/* Reads any format OpenImageIO knows, as float values as stored (no colour conversion); a regular
 * file only, of at most IMAGE_MAX_PIXELS pixels. Sets stored_8bit when the file's samples are 8-bit
 * unsigned integers (PNG, JPEG, TGA, BMP, 8-bit TIFF...), which by convention are sRGB-encoded: the
 * texture loader decodes those. */
int image_read(const char *path, image *out, vx_err *e);

/* The voxlab provenance attributes (IMAGE_META_PREFIX) of an EXR file's header; none (count 0)
 * for another format or a file without them. -1 only when an EXR cannot be read. */
int image_read_meta(const char *path, image_meta *out, vx_err *e);

/* --- Pieces the writers share (image.c, image_exr.c, image_oiio.cpp); usable by tests. --- */

/* Linear value -> 8-bit sRGB code: IEC 61966-2-1 curve, clamped to [0,1] (NaN -> 0), rounded. */
unsigned char image_linear_to_srgb8(float linear);

/* Writes already-encoded 8-bit samples as a PNG at exactly `path` through OpenImageIO, which
 * only stores them (no colour conversion, no alpha association). `what` names the file in errors. */
int image_write_png8_oiio(const unsigned char *px, int width, int height, int channels, const char *path,
                          const char *what, vx_err *e);

#ifdef __cplusplus
}
#endif

#endif
