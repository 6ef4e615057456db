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
void texture_free(texture *t);

#ifdef __cplusplus
}
#endif

#endif
