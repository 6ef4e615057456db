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

#endif
