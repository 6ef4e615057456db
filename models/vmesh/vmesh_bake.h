/* `vmesh` bake side (Brito et al. 2023, §3.2-3.4): the pieces that turn one voxel's sample rays into
 * a vmesh_record. Host C only (may allocate); the tests call the pieces one by one. */
#ifndef VX_VMESH_BAKE_H
#define VX_VMESH_BAKE_H

#include "sggx_fit.h"
#include "vmesh_record.h"

/* The SGGX frame of the voxel's normals: sggx_fit (models/common/sggx_fit.h) with VMESH_MIN_AREA. */

/* The normals a face stores, one per vertex (vertex k lies along vertex_dir[k]). With 1-3 distinct
 * normals (clusters 5 degrees apart) they are the clusters' mean normals, each on its own vertex
 * (where it points most along the vertex), free vertices holding the zero vector; with more, the
 * face holds a distribution: three extremal normals on the cone around the mean normal (opening
 * max(theta_max, 0.1 rad)), placed to enclose as many of the normals with as little empty cone as
 * possible. No normals: three zero vectors. */
typedef struct {
    vec3 normal[3];
    int distribution;
    int distinct; /* clusters found (4 means "more than 3") */
} vmesh_face_fit;

void vmesh_fit_face(const vec3 *normals, int n, const vec3 vertex_dir[3], vmesh_face_fit *out);

/* The 3x3x3 subgrid opacities of a voxel (index (i * 3 + j) * 3 + k): per sub-cell, the mean
 * occlusion value of the sample rays whose chord [t_entry, t_exit] crosses it, 0 for sub-cells
 * holding no front-facing hit. A ray's occlusion value is 1 when it hit inside the voxel (front or
 * back) or hit one of the voxel's own triangles beyond it, else 0. */
void vmesh_subgrid(const vx_voxel *v, const vx_sample *samples, int n, float opacity[VMESH_SUBCELLS]);

/* The sub-cells a chord crosses, in order, in lattice units (the voxel is [0, 3]^3): entry point e,
 * direction d (scaled like the lattice), parameter length len. Pieces shorter than 1e-6 len are
 * skipped. Returns the count (at most 7). */
int vmesh_chord_cells(vec3 e, vec3 d, float len, int cells[8]);

/* vx_model.bake_voxel: fills the vmesh_record `out` (zeroed by the caller). */
void vmesh_bake_voxel(const vx_voxel *v, const vx_sample *samples, int n, void *out);

/* The record's encoders (what the bake writes; the moving operations re-encode with them):
 * [-1, 1] -> signed byte x127, [0, 1] -> unsigned byte x255 (NaN and negatives 0). */
signed char vmesh_encode_snorm(float x);
unsigned char vmesh_encode_unorm(float x);
void vmesh_encode_vec(vec3 v, signed char out[3]);

/* The octant face of a normal in a decoded frame (vmesh_record.h's indexing). */
int vmesh_face_of(const vmesh_octahedron *o, vec3 n);

/* The frame (axes and projected areas) into r's axis and area bytes. */
void vmesh_encode_frame(vmesh_record *r, const sggx_frame *fit);

/* The faces of r (normals, colours, faces and distribution bits) from n unit normals with their
 * albedos and weights (NULL: 1 each), sorted into the octants of r's frame as the renderer decodes
 * it (so the frame must be encoded first) by sort_dir (NULL: the normals themselves; vmesh_combine
 * sorts the normals of one stored face together, by their mean) and fitted per face with
 * vmesh_fit_face; a face's colour is the weighted mean albedo of its normals. face (n ints)
 * receives each normal's face, sorted (n vectors) is scratch. Used by the bake and by
 * vmesh_combine (vmesh_move.c). */
void vmesh_build_faces(vmesh_record *r, const vec3 *normals, const vec3 *albedo, const float *weight,
                       const vec3 *sort_dir, int n, int *face, vec3 *sorted);

/* vx_model.transform and .combine (vmesh_move.c). */
void vmesh_transform(const void *in, const float R[9], void *out);
void vmesh_combine(const struct vx_record_part *parts, int n, float voxel_size, void *out);

#endif
