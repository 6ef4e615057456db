/* `vmesh` (Brito, Poulin, Teichrieb 2023): the per-voxel record and its decoding. Portable C (also
 * OpenCL C): shared by the bake (which encodes through the same decoders, so both sides agree on
 * the octahedron) and by the per-voxel evaluation in vmesh_opacity.h and vmesh_shade.h.
 *
 * Layout (§4 of the paper, all bytes, no padding): 139 bytes
 *   axis[3][3]      9  SGGX eigenvectors, signed bytes (x127), right-handed, descending 2nd moment
 *   area[3]         3  projected-area eigenvalues lambda_k = mean |v_k . n| in [0.1, 1] (x255)
 *   normal[8][3][3] 72 per octahedron face, one normal per vertex (signed bytes, x127; (0,0,0) = no
 *                      normal on that vertex, for faces with fewer than 3 distinct normals)
 *   color[8][3]     24 per face, the mean albedo of its normals (x255, linear)
 *   faces           1  bit f: face f holds data
 *   distribution    1  bit f: face f's three normals are extremal normals of a cone (interpolate)
 *                      rather than 1-3 distinct normals (pick the nearest vertex)
 *   opacity[27]     27 3x3x3 subgrid opacities (x255), index (i * 3 + j) * 3 + k for x, y, z
 *   specular        1  mean specular reflectance of the front hits (x255)
 *   roughness       1  mean Beckmann roughness, stored as 255 sqrt(alpha / 2) (precision at small alpha)
 * The paper reports "approximately 143 bytes" without itemising them (a boolean byte per face
 * instead of our two bit masks would make 145).
 *
 * Faces are indexed by octant: bit 0 of f set = the face's vertex on axis 0 is the negative one, bit
 * 1 for axis 1, bit 2 for axis 2. The face of octant (s0, s1, s2) has vertices s_k a_k v_k (k = 0, 1,
 * 2) in that order, counter-clockwise seen from outside when s0 s1 s2 > 0 and clockwise otherwise;
 * normal[f][k] belongs to the vertex on axis k. This is the authors' face list
 * ({0,2,4}, {0,4,3}, ...) with the octant as the index, which is what assigning a normal to its
 * face needs anyway. */
#ifndef VX_VMESH_RECORD_H
#define VX_VMESH_RECORD_H

#include "model.h"

#define VMESH_FACES 8
#define VMESH_SUB 3
#define VMESH_SUBCELLS 27
#define VMESH_MIN_AREA 0.1f /* the authors' clamp of the projected areas */

typedef struct {
    signed char axis[3][3];
    unsigned char area[3];
    signed char normal[VMESH_FACES][3][3];
    unsigned char color[VMESH_FACES][3];
    unsigned char faces;
    unsigned char distribution;
    unsigned char opacity[VMESH_SUBCELLS];
    unsigned char specular;
    unsigned char roughness;
} vmesh_record;

/* The virtual octahedron in world orientation: unit axes and the vertex distance along each. */
typedef struct {
    vec3 axis[3];
    float extent[3];
} vmesh_octahedron;

VX_INLINE vec3 vmesh_decode_vec(VX_GLOBAL const signed char *q)
{
    return v3((float)q[0] * (1.0f / 127.0f), (float)q[1] * (1.0f / 127.0f), (float)q[2] * (1.0f / 127.0f));
}

VX_INLINE float vmesh_decode_unorm(unsigned char q) { return (float)q * (1.0f / 255.0f); }

VX_INLINE float vmesh_decode_roughness(unsigned char q)
{
    float s = vmesh_decode_unorm(q);
    return vx_fmaxf(2.0f * s * s, 1e-3f); /* the scene loader's lower bound */
}

/* The octahedron of a record. Quantised eigenvectors are no longer exactly orthonormal:
 * Gram-Schmidt in storage order restores a frame (the bake stored a right-handed one, and the
 * quantisation error of 1/254 per component cannot flip it).
 *
 * Vertex distances: the SGGX ellipsoid of projected areas lambda_k has semi-axes proportional to
 * 1 / lambda_k (a surface whose normals all point along v_0 is a flat disk across v_0, not a
 * needle along it); then the octahedron's projected area along v_k is proportional to lambda_k, as
 * the microflakes' is, and the face of an octant has the normal (s0 l0, s1 l1, s2 l2) in the
 * eigenframe. Scaled so that the largest distance is 1 (only ratios of areas are ever used). */
VX_INLINE vmesh_octahedron vmesh_decode_octahedron(VX_GLOBAL const vmesh_record *r)
{
    vmesh_octahedron o;
    vec3 a0 = vmesh_decode_vec(r->axis[0]), a1 = vmesh_decode_vec(r->axis[1]), a2 = vmesh_decode_vec(r->axis[2]);
    o.axis[0] = v3_normalize_or(a0, v3(1.0f, 0.0f, 0.0f));
    vec3 t = v3_madd(a1, o.axis[0], -v3_dot(a1, o.axis[0]));
    vec3 t0, b0;
    v3_basis(o.axis[0], &t0, &b0);
    o.axis[1] = v3_normalize_or(t, t0);
    vec3 c = v3_cross(o.axis[0], o.axis[1]);
    o.axis[2] = v3_dot(c, a2) < 0.0f ? v3_scale(c, -1.0f) : c;
    float lmin = 1.0f;
    float l[3];
    for (int k = 0; k < 3; k++) {
        l[k] = vx_fmaxf(vmesh_decode_unorm(r->area[k]), VMESH_MIN_AREA);
        lmin = vx_fminf(lmin, l[k]);
    }
    for (int k = 0; k < 3; k++)
        o.extent[k] = lmin / l[k];
    return o;
}

/* Vertex k (on axis k) of face f. */
VX_INLINE vec3 vmesh_face_vertex(const vmesh_octahedron *o, int f, int k)
{
    float s = ((f >> k) & 1) ? -1.0f : 1.0f;
    return v3_scale(o->axis[k], s * o->extent[k]);
}

/* Signed area of face f projected along the unit direction w toward the viewer: positive when the
 * face's outside faces w. */
VX_INLINE float vmesh_face_projected_area(const vmesh_octahedron *o, int f, vec3 w)
{
    vec3 p0 = vmesh_face_vertex(o, f, 0), p1 = vmesh_face_vertex(o, f, 1), p2 = vmesh_face_vertex(o, f, 2);
    float orient = ((f ^ (f >> 1) ^ (f >> 2)) & 1) ? -1.0f : 1.0f; /* s0 s1 s2 */
    return 0.5f * orient * v3_dot(v3_cross(v3_sub(p1, p0), v3_sub(p2, p0)), w);
}

#endif
