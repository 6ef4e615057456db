#include "texture.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "fileio.h"
#include "image.h"

static float wrap01(float x) { return x - floorf(x); }

vec3 texture_lookup(const texture *t, float u, float v)
{
    if (t->kind == TEXTURE_CHECKER) {
        int cu = (int)floorf(u * t->scale), cv = (int)floorf(v * t->scale);
        return ((cu + cv) & 1) ? t->color2 : v3(1.0f, 1.0f, 1.0f);
    }
    /* Bilinear with repeat wrapping, texel centres at half-integers. */
    float x = wrap01(u) * (float)t->width - 0.5f, y = (1.0f - wrap01(v)) * (float)t->height - 0.5f;
    int x0 = (int)floorf(x), y0 = (int)floorf(y);
    float fx = x - (float)x0, fy = y - (float)y0;
    vec3 acc = v3(0, 0, 0);
    for (int k = 0; k < 4; k++) {
        int xi = x0 + (k & 1), yi = y0 + (k >> 1);
        xi = ((xi % t->width) + t->width) % t->width;
        yi = ((yi % t->height) + t->height) % t->height;
        float w = ((k & 1) ? fx : 1.0f - fx) * ((k >> 1) ? fy : 1.0f - fy);
        const float *p = &t->rgb[3 * ((size_t)yi * (size_t)t->width + (size_t)xi)];
        acc = v3_madd(acc, v3(p[0], p[1], p[2]), w);
    }
    return acc;
}

/* 8-bit image formats store sRGB-encoded values; EXR, HDR and PFM store linear ones. A file counts
 * as sRGB when its samples are 8-bit (whatever the format: a TGA, BMP or 8-bit TIFF as much as a PNG;
 * by extension alone those were read as linear, 0.78 for a texel of 200 instead of 0.58) or when it
 * is a PNG or JPEG (whose 16-bit samples are sRGB-encoded too). */
static int stores_srgb(const char *path, const image *img)
{
    if (img->stored_8bit)
        return 1;
    const char *dot = fileio_extension(path);
    return strcasecmp(dot, ".png") == 0 || strcasecmp(dot, ".jpg") == 0 || strcasecmp(dot, ".jpeg") == 0;
}

static float srgb_to_linear(float x) { return x <= 0.04045f ? x / 12.92f : powf((x + 0.055f) / 1.055f, 2.4f); }

int texture_load_image(texture *t, const char *path, vx_err *e)
{
    image img = {0};
    if (image_read(path, &img, e))
        return -1;
    int srgb = stores_srgb(path, &img);
    memset(t, 0, sizeof *t);
    t->kind = TEXTURE_IMAGE;
    t->width = img.width;
    t->height = img.height;
    t->rgb = malloc(sizeof(float) * 3 * (size_t)img.width * (size_t)img.height);
    if (!t->rgb) {
        image_free(&img);
        return vx_fail(e, "%s: out of memory for the texture", path);
    }
    for (size_t i = 0; i < (size_t)img.width * (size_t)img.height; i++)
        for (int c = 0; c < 3; c++) {
            float x = img.data[i * (size_t)img.channels + (size_t)(img.channels >= 3 ? c : 0)];
            if (!isfinite(x)) {
                image_free(&img);
                texture_free(t);
                return vx_fail(e, "%s: texel %zu is not finite", path, i);
            }
            /* An albedo (scene.c's parse_albedo says why): a float format may hold anything. */
            if (!(x >= 0.0f && x <= 1.0f)) {
                image_free(&img);
                texture_free(t);
                return vx_fail(e, "%s: texel %zu (x %zu, y %zu) channel %d is %g: expected an albedo from 0 to 1", path,
                               i, i % (size_t)t->width, i / (size_t)t->width, c, x);
            }
            t->rgb[3 * i + (size_t)c] = srgb ? srgb_to_linear(x) : x;
        }
    image_free(&img);
    return 0;
}

int texture_from_srgb8(texture *t, int width, int height, int components, const unsigned char *texels, vx_err *e)
{
    memset(t, 0, sizeof *t);
    if (width < 1 || height < 1 || components < 1 || components > 4 || (long long)width * height > IMAGE_MAX_PIXELS)
        return vx_fail(e, "texture of %dx%d texels with %d components: expected 1..4 components, at most %lld texels",
                       width, height, components, (long long)IMAGE_MAX_PIXELS);
    t->kind = TEXTURE_IMAGE;
    t->width = width;
    t->height = height;
    t->rgb = malloc(sizeof(float) * 3 * (size_t)width * (size_t)height);
    if (!t->rgb)
        return vx_fail(e, "out of memory for a %dx%d texture", width, height);
    for (int y = 0; y < height; y++)
        for (int x = 0; x < width; x++) {
            const unsigned char *p = &texels[((size_t)(height - 1 - y) * (size_t)width + (size_t)x) * (size_t)components];
            float *dst = &t->rgb[3 * ((size_t)y * (size_t)width + (size_t)x)];
            for (int c = 0; c < 3; c++)
                dst[c] = srgb_to_linear((float)p[components >= 3 ? c : 0] * (1.0f / 255.0f));
        }
    return 0;
}

void texture_free(texture *t)
{
    free(t->rgb);
    t->rgb = NULL;
}
