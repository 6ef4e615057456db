/* Loop subdivision (Loop 1987) of one object's triangles: the scene's `"subdivide": k` field. Each
 * level splits every triangle into four and moves every vertex by Loop's masks, so the surface is a
 * smooth refinement of the input, not the same facets cut smaller (issue 19's dense meshes). */
#ifndef VX_MESH_SUBDIVIDE_H
#define VX_MESH_SUBDIVIDE_H

#include <cjson/cJSON.h>
#include <stddef.h>

#include "error.h"
#include "mesh.h"

#define SUBDIVIDE_MAX_LEVELS 4
/* The object's triangles after subdivision: indices stay 32-bit with room to spare. */
#define SUBDIVIDE_MAX_TRIANGLES ((size_t)1 << 28)

/* Subdivides the triangles from t0 on, which must use only the vertices from v0 on (one object, the
 * last one in the mesh), `levels` times. Connectivity is by vertex index (vertices split at a seam
 * stay split). Rules (Loop 1987; boundaries as Hoppe et al. 1994):
 *  - an edge shared by two triangles gets the vertex 3/8 (a + b) + 1/8 (c + d), c and d opposite;
 *    any other edge (a boundary, or non-manifold) gets the midpoint;
 *  - an interior vertex of valence n becomes (1 - n beta) v + beta * sum(neighbours), beta = 1/n
 *    (5/8 - (3/8 + 1/4 cos(2 pi / n))^2); a vertex on exactly two boundary edges becomes 3/4 v + 1/8
 *    (its two boundary neighbours), so the boundary converges to the cubic B-spline of its polygon
 *    and stays on it; a vertex with another number of boundary edges (a corner of several patches, a
 *    non-manifold one) stays where it is.
 * Colours and texture coordinates: kept at the old vertices, the midpoint on edge vertices (linear,
 * so texture seams do not drift). Every triangle's four children keep its material and winding.
 * Normals are recomputed smooth and area-weighted from the refined surface (mesh_smooth_normals),
 * as the loaders do for files without normals. Deterministic; memory and time linear in the output.
 * Returns -1 (mesh unchanged) when the result would exceed SUBDIVIDE_MAX_TRIANGLES or memory. */
int mesh_subdivide(mesh *m, size_t v0, size_t t0, int levels, vx_err *e);

/* The object field "subdivide": k (an integer 0..SUBDIVIDE_MAX_LEVELS; absent: 0) read from object
 * `o` into *levels, before the object is loaded (a glTF's loader must know: mesh_load_gltf_files);
 * `where` names the object in messages ("scene.json: objects[0]"). */
int mesh_subdivide_levels(const cJSON *o, const char *where, int *levels, vx_err *e);
/* Those levels applied to the object's vertices from v0 and triangles from t0 on (mesh_subdivide),
 * its errors naming the field. */
int mesh_subdivide_object(mesh *m, size_t v0, size_t t0, int levels, const char *where, vx_err *e);

#endif
