/* The "heightfield" generator's surface, exposed so tests can compute exact statistics of what the
 * generator meshed (Heitz & Neyret's validation case: a Gaussian random height field whose colour
 * correlates with height).
 *
 * h(x, z) = A * sum_w cos(kx_w x + kz_w z + phase_w) over the patch [-size/2, size/2]^2, A =
 * sigma_h * sqrt(2 / waves). The wave vectors are distinct points of the patch's Fourier lattice
 * (2 pi / size) * (m, n), so the waves are exactly orthogonal over the patch (and over the mesh's
 * vertex grid): mean(h) = 0 and std(h) = sigma_h exactly, not just on average over seeds, and the
 * surface tiles. The sum of many random-phase waves is close to Gaussian.
 *
 * Colour: mean_color + s(h) * delta_color with s(h) = 2 G(h) - 1 = erf(h / (sqrt(2) sigma_h)),
 * G being the Gaussian CDF of the heights. */
#ifndef VX_HEIGHTFIELD_H
#define VX_HEIGHTFIELD_H

#include <cjson/cJSON.h>
#include <stdint.h>

#include "error.h"
#include "generator.h"
#include "vec.h"

typedef struct {
    double size;
    int resolution; /* quads per side of the mesh */
    double sigma_h;
    double wavelength_min, wavelength_max;
    int wave_count;
    double amplitude;         /* A, the same for every wave */
    double *kx, *kz, *phase;  /* wave_count each */
    vec3 mean_color, delta_color;
} heightfield_surface;

#ifdef __cplusplus
extern "C" {
#endif

/* Reads the generator's params (NULL = all defaults) exactly as the generator does, and draws the
 * waves for `seed`. Errors name the offending field under `where`. */
int heightfield_surface_init(heightfield_surface *s, const cJSON *params, const char *where, uint64_t seed,
                             vx_err *e);
void heightfield_surface_free(heightfield_surface *s);

/* Height, unit normal (normalize(-dh/dx, 1, -dh/dz)) and colour at (x, z); normal and color may be
 * NULL. At a mesh vertex, called with the vertex's own float x and z, this returns bit for bit the
 * double height the vertex was made from (its y is that rounded to float). */
double heightfield_eval(const heightfield_surface *s, double x, double z, vec3 *normal, vec3 *color);

/* s(h) = erf(h / (sqrt(2) sigma_h)), in (-1, 1). */
double heightfield_color_weight(const heightfield_surface *s, double h);
vec3 heightfield_color(const heightfield_surface *s, double h);

extern const scene_generator generator_heightfield;

#ifdef __cplusplus
}
#endif

#endif
