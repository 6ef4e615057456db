/* A triangle mesh being built: positions, shading normals and texture coordinates per vertex,
 * a material index per triangle. Scene loaders and procedural generators append to it. */
#ifndef VX_MESH_H
#define VX_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "vec.h"

typedef struct {
    float *positions; /* 3 per vertex */
    float *normals;   /* 3 per vertex, unit length */
    float *uvs;       /* 2 per vertex */
    float *colors;    /* 3 per vertex, multiplies the material's colour; white unless set */
    size_t vertex_count, vertex_capacity;
    uint32_t *indices;   /* 3 per triangle */
    uint32_t *materials; /* 1 per triangle */
    size_t triangle_count, triangle_capacity;
    int normals_smoothed; /* set by mesh_smooth_normals: a loader computed normals the file lacked, or
                           * a subdivision recomputed them (the scene then gives a PLY or OBJ object
                           * creases, mesh_crease_normals) */
} mesh;

#ifdef __cplusplus
extern "C" {
#endif

void mesh_free(mesh *m);
/* Appends a vertex and returns its index. Allocation failure aborts with a message: a mesh too
 * large for memory is not a recoverable input error. */
uint32_t mesh_add_vertex(mesh *m, vec3 position, vec3 normal, float u, float v);
void mesh_add_triangle(mesh *m, uint32_t a, uint32_t b, uint32_t c, uint32_t material);
/* A flat-shaded triangle with its own three vertices (normal from the winding, counter-clockwise
 * = front). */
void mesh_add_flat_triangle(mesh *m, vec3 a, vec3 b, vec3 c, uint32_t material);
/* A flat quad a,b,c,d (counter-clockwise seen from the front) as two triangles, uv 0..1. */
void mesh_add_quad(mesh *m, vec3 a, vec3 b, vec3 c, vec3 d, uint32_t material);
/* An axis-aligned box with outward-facing flat faces. */
void mesh_add_box(mesh *m, vec3 lo, vec3 hi, uint32_t material);
/* Replaces every vertex normal by the area-weighted mean of its triangles' normals (for meshes
 * that come without normals, such as the PLY scans). */
void mesh_smooth_normals(mesh *m, size_t first_vertex, size_t first_triangle);
/* The crease angle of normals computed for a file without them: Unity's default smoothing angle. A
 * cube's 90-degree edges stay sharp, an icosphere's 42 degrees and a scan's noise mostly do not. */
#define MESH_CREASE_DEG 60.0f
/* Smooth area-weighted normals that stay sharp across creases (the triangles from first_triangle
 * on, which use only the vertices from first_vertex on): each triangle corner takes the
 * area-weighted mean of the normals of the triangles around its vertex that lie within crease_deg
 * of its own triangle's; a vertex whose corners end up with different normals is split, the copies
 * appended to the mesh and the triangles' indices rewritten. Why: mesh_smooth_normals rounds a
 * cube whose faces share their corners into a blob of normals, whose faces the truth then lights
 * only from above their geometric plane (a light below the triangle cannot reach it) while a voxel
 * model, which sees only the shading normals, lights them as the normals say: a bias no voxel size
 * removed (binary +13 % on a rotated cube). Deterministic: corners are visited in triangle order. */
void mesh_crease_normals(mesh *m, size_t first_vertex, size_t first_triangle, float crease_deg);
/* Flat normals, as glTF 2.0 asks of a primitive without NORMAL ("client implementations MUST
 * calculate flat normals"): each triangle from first_triangle on (which use only the vertices from
 * first_vertex on) gets three vertices of its own, in triangle order, that carry its geometric
 * normal (counter-clockwise = front; +z for a zero-area one) and the position, uv and colour of the
 * corner each came from. The vertices from first_vertex on are replaced (3 per triangle; one no
 * triangle uses is gone). Leaves normals_smoothed alone: these normals need no creases. The
 * caller keeps 3 x the triangles within 32-bit indices. */
void mesh_flat_normals(mesh *m, size_t first_vertex, size_t first_triangle);
vec3 mesh_position(const mesh *m, uint32_t vertex);
void mesh_set_vertex_color(mesh *m, uint32_t vertex, vec3 color);

#ifdef __cplusplus
}
#endif

#endif
