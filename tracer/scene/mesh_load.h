/* Loading triangle meshes from files into a mesh (see mesh.h). Every triangle gets `material`
 * (glTF files may carry their own base colours: see mesh_load_gltf). Errors name the file and what
 * was wrong with it; on error the mesh keeps its earlier vertices, triangles and counts unchanged. */
#ifndef VX_MESH_LOAD_H
#define VX_MESH_LOAD_H

#include "error.h"
#include "mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Binary (little or big endian) or ASCII PLY: "vertex" element with x, y, z (optional nx, ny, nz;
 * red/green/blue as uchar 0..255 or float 0..1; u/v or s/t), of any PLY scalar type in any order,
 * other properties and elements (lists included) skipped; "face" element with a vertex_indices (or
 * vertex_index) list of integers (polygons are fan-triangulated, zero-area triangles kept). Without
 * normals in the file, smooth area-weighted normals are computed (mesh_smooth_normals; a scene's
 * object then gives them creases, mesh_crease_normals). Non-finite coordinates,
 * out-of-range indices, truncated data are errors. */
int mesh_load_ply(const char *path, mesh *out, uint32_t material, vx_err *e);

/* Wavefront OBJ through tinyobjloader: `v` positions, `vn` normals, `vt` texture coordinates, `f`
 * faces (polygons fan-triangulated; negative, relative indices allowed); `mtllib`, materials,
 * groups and other statements ignored (the scene's material applies). Corners sharing position,
 * normal and uv share a vertex; without any `vn`, smooth area-weighted normals are computed (as for
 * a PLY: creases come from the scene). Indices
 * out of range, non-finite values and a file without faces are errors. */
int mesh_load_obj(const char *path, mesh *out, uint32_t material, vx_err *e);

/* glTF 2.0, .gltf (with external or data-URI buffers) or .glb, through tinygltf. Every mesh
 * primitive of mode TRIANGLES in the default scene (or under every root node when there is none) is
 * added with its node transforms applied (winding swapped under mirroring transforms); POSITION is
 * required, NORMAL and TEXCOORD_0 are used when present; a primitive without NORMAL gets flat
 * normals, as the spec asks (mesh_flat_normals: three vertices of its own per triangle); here
 * (without the material callback of mesh_load_gltf_materials) a material's baseColorFactor (times
 * COLOR_0, if any) becomes the vertex colour and images are not decoded. A file with no triangle
 * primitive, an accessor outside its buffer, a non-finite position or compressed geometry (Draco,
 * meshopt) is an error. */
int mesh_load_gltf(const char *path, mesh *out, uint32_t material, vx_err *e);
/* The same; external files (buffer URIs) are read only from inside the glTF's own folder unless
 * uris_anywhere is set (the scene's "uris_outside_folder": true). */
int mesh_load_gltf_uris(const char *path, mesh *out, uint32_t material, int uris_anywhere, vx_err *e);

/* A glTF material as the file gives it: its base colour factor and, when it has a
 * baseColorTexture read through TEXCOORD_0, the texture decoded (8-bit sRGB texels, `components`
 * per texel, row 0 the image's top: glTF's v = 0). */
typedef struct {
    const char *name;
    double base_color[4];
    const unsigned char *texels; /* NULL: no texture */
    int width, height, components;
} gltf_material_desc;
/* Makes the voxlab material for glTF material `index`: writes its index into *material, or returns
 * -1 with a message. Called once per glTF material a loaded primitive uses. */
typedef int (*gltf_material_fn)(void *ctx, int index, const gltf_material_desc *d, uint32_t *material, vx_err *e);
/* glTF with its own materials: primitives with a material get the one make_material returns (the
 * base colour then is the material's, not a vertex colour; COLOR_0 still multiplies it), those
 * without get `material`. Images are decoded (at most IMAGE_MAX_PIXELS each). */
int mesh_load_gltf_materials(const char *path, mesh *out, uint32_t material, int uris_anywhere,
                             gltf_material_fn make_material, void *ctx, vx_err *e);
/* Told the path of each external file (a buffer or an image URI) a successful glTF load read, once
 * each; returns 0, or -1 to fail the load (out of memory). */
typedef int (*gltf_file_fn)(void *ctx, const char *file);
/* mesh_load_gltf_materials that also reports the external files it read to on_file (NULL: not).
 * to_subdivide: the object will be subdivided (mesh_subdivide), so a primitive without NORMAL
 * keeps its shared vertices with smooth normals (mesh_smooth_normals) instead of flat ones: the
 * subdivision connects triangles by vertex index and recomputes the normals itself. */
int mesh_load_gltf_files(const char *path, mesh *out, uint32_t material, int uris_anywhere, int to_subdivide,
                         gltf_material_fn make_material, void *ctx, gltf_file_fn on_file, void *file_ctx, vx_err *e);

#ifdef __cplusplus
}
#endif

#endif
