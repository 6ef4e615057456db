/* Textures for material colour: an image (read with OpenImageIO) or a procedural checker.
 * Looked up by uv with repeat wrapping; only used when a scene declares "textures". */
#ifndef VX_TEXTURE_H
#define VX_TEXTURE_H

#include "error.h"
#include "vec.h"

enum { TEXTURE_IMAGE = 0, TEXTURE_CHECKER = 1 };

typedef struct {
    int kind;
    int width, height; /* image */
    float *rgb;        /* image: linear RGB, row 0 at v = 1 */
    float scale;       /* checker: squares per unit of uv */
    vec3 color2;       /* checker: the second colour (the first is white, i.e. the material colour) */
} texture;

#ifdef __cplusplus
extern "C" {
#endif

/* Multiplier of the material colour at (u, v). */
vec3 texture_lookup(const texture *t, float u, float v);
int texture_load_image(texture *t, const char *path, vx_err *e);
/* An image texture from 8-bit sRGB texels (components 1-4 per texel, alpha ignored), row 0 the
 * image's top at v = 0 (glTF's convention; stored flipped for texture_lookup's v = 1 at the top). */
int texture_from_srgb8(texture *t, int width, int height, int components, const unsigned char *texels, vx_err *e);
void texture_free(texture *t);

#ifdef __cplusplus
}
#endif

#endif
