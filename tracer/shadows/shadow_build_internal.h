/* What the slicemap builders share (shadow_build.c, slicemap_triangles.c, slicemap_model.c): one
 * light's map while it is built, its light-space frame and column rays, and the step that turns a
 * column's transmittance profile into bits and T values. */
#ifndef VX_SHADOW_BUILD_INTERNAL_H
#define VX_SHADOW_BUILD_INTERNAL_H

#include "shadow_set.h"

typedef struct map_build {
    shadow_map_params m;
    float len;      /* the columns' length (depth range) */
    double du, dv;  /* column width (world units, or tangent units for a frustum) */
    uint64_t *bits; /* res * res * words, column (i, j) at (j * res + i) * words */
    float *opaque;  /* res * res (slicemap only) */
    float **row_T;  /* per row j: the T values of its columns, column after column */
    size_t *row_n, *row_cap;
    int failed;     /* out of memory in a row */
} map_build;

/* Sets up b for light L of s: the frame around the scene's bounds, res columns per side, slices a
 * multiple of 64 near res; allocates the bits (and the opaque map when has_opaque). Fails for a
 * point light inside the scene's bounding sphere (a frustum cannot see all of the scene). */
int shadow_frame(const scene *s, const light *L, int li, int res, int has_opaque, map_build *b, vx_err *e);
/* The test of shadow_frame that refuses point light li of s: inside the scene's bounding sphere,
 * from where one frustum cannot see all of the scene (shadow_check_lights asks it before any work). */
int shadow_point_light_refused(const scene *s, const light *L, int li, vx_err *e);
void map_build_free(map_build *b);

/* The ray of column (i, j): from the near plane toward the scene (from_far 0: depth = t) or from the
 * far plane toward the light (from_far 1: depth = len - t), over t in [0, len]. */
void shadow_column_ray(const map_build *b, int i, int j, int from_far, vec3 *org, vec3 *dir);
/* Half a column's width at depth d (the footprint of a column's ray there). */
float shadow_column_radius(const map_build *b, float d);
/* The slice holding depth d (clamped to the column). */
int shadow_slice(const map_build *b, float d);

/* Column (i, j) from cum[k], the transmittance from the light through slice k inclusive
 * (non-increasing in k): a bit for every slice where it drops, with its value appended to row j.
 * Called for the columns of a row in order of i, by one thread per row. */
void shadow_column_finish(map_build *b, int i, int j, const float *cum);

/* The triangles' slicemap of one light (slicemap_triangles.c; a model's: slicemap_model.c, declared
 * in shadow_set.h). */
int slicemap_fill_triangles(const scene *s, map_build *b, int threads, vx_err *e);

#endif
