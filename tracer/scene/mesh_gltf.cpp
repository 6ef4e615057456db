// glTF 2.0 loading for mesh_load_gltf through tinygltf (Debian's shared libtinygltf: the
// implementation lives in the library, so TINYGLTF_IMPLEMENTATION must not be defined here).
// tinygltf parses the JSON and decodes buffers; it does not check that accessors stay inside their
// buffers, so every accessor is validated here before a byte of it is read. Errors inside the
// loader are thrown as load_error and turned into a vx_err at the C boundary, which also catches
// anything else C++ may throw (std::bad_alloc from tinygltf's vectors, for instance).
#include "mesh_load.h"
#include "mesh_load_cpp.h"
#include "image.h"
#include "json_util.h"
#include "readfile.h"

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <unistd.h>

#include <cjson/cJSON.h>
#include <stb/stb_image.h>
#include <tiny_gltf.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

namespace {

using vx_mesh_load::fail;
using vx_mesh_load::load_error;
using vx_mesh_load::trimmed;

// 4x4 matrices column-major, as glTF stores them: m[col * 4 + row].
using mat4 = std::array<double, 16>;

mat4 identity()
{
    mat4 m{};
    m[0] = m[5] = m[10] = m[15] = 1.0;
    return m;
}

mat4 mul(const mat4 &a, const mat4 &b)
{
    mat4 r{};
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += a[k * 4 + row] * b[c * 4 + k];
            r[c * 4 + row] = s;
        }
    return r;
}

// A node's local transform: its matrix when given, else T * R * S (the order glTF specifies).
mat4 node_local(const tinygltf::Node &n, const std::string &where)
{
    if (n.matrix.size() == 16) {
        mat4 m;
        for (int i = 0; i < 16; i++)
            m[i] = n.matrix[i];
        return m;
    }
    if (!n.matrix.empty())
        fail(where + ": matrix has " + std::to_string(n.matrix.size()) + " values (expected 16)");
    double t[3] = {0, 0, 0}, s[3] = {1, 1, 1}, q[4] = {0, 0, 0, 1};
    if (n.translation.size() == 3)
        for (int i = 0; i < 3; i++)
            t[i] = n.translation[i];
    if (n.scale.size() == 3)
        for (int i = 0; i < 3; i++)
            s[i] = n.scale[i];
    if (n.rotation.size() == 4) {
        // Normalised so that exporters' slightly-off quaternions do not scale the mesh.
        double len = std::sqrt(n.rotation[0] * n.rotation[0] + n.rotation[1] * n.rotation[1] +
                               n.rotation[2] * n.rotation[2] + n.rotation[3] * n.rotation[3]);
        if (len > 0.0)
            for (int i = 0; i < 4; i++)
                q[i] = n.rotation[i] / len;
    }
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double r[9] = {// column-major rotation matrix of the unit quaternion (x, y, z, w)
                   1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                   2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                   2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
    mat4 m = identity();
    for (int c = 0; c < 3; c++)
        for (int row = 0; row < 3; row++)
            m[c * 4 + row] = r[c * 3 + row] * s[c];
    m[12] = t[0];
    m[13] = t[1];
    m[14] = t[2];
    return m;
}

// A validated view of an accessor's elements: element i starts at base + i * stride.
struct accessor_view {
    const unsigned char *base = nullptr; // null: no bufferView, every element is zero (glTF spec)
    size_t stride = 0, count = 0;
    int component_type = 0, components = 0;
    bool normalized = false;
};

size_t component_size(int t)
{
    switch (t) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
    }
}

int type_components(int t)
{
    switch (t) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    default: return 0;
    }
}

const char *component_name(int t)
{
    switch (t) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return "byte";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "unsigned byte";
    case TINYGLTF_COMPONENT_TYPE_SHORT: return "short";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "unsigned short";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "unsigned int";
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return "float";
    default: return "unknown";
    }
}

// Resolves accessor `index` and checks that all of its elements lie inside its bufferView and the
// view inside its buffer; `what` names the use for messages ("POSITION of mesh 0 primitive 1").
accessor_view resolve_accessor(const tinygltf::Model &model, int index, const std::string &what)
{
    std::string where = "accessor " + std::to_string(index) + " (" + what + ")";
    if (index < 0 || size_t(index) >= model.accessors.size())
        fail(where + " does not exist (the file has " + std::to_string(model.accessors.size()) +
             " accessors)");
    const tinygltf::Accessor &a = model.accessors[size_t(index)];
    if (a.sparse.isSparse)
        fail(where + " is sparse (sparse accessors are not supported)");
    accessor_view v;
    v.count = a.count;
    v.component_type = a.componentType;
    v.components = type_components(a.type);
    v.normalized = a.normalized;
    size_t elem = component_size(a.componentType) * size_t(v.components);
    if (elem == 0)
        fail(where + " has an unknown component type or element type");
    if (a.bufferView < 0)
        return v;
    if (size_t(a.bufferView) >= model.bufferViews.size())
        fail(where + " refers to bufferView " + std::to_string(a.bufferView) + ", which does not exist");
    const tinygltf::BufferView &bv = model.bufferViews[size_t(a.bufferView)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= model.buffers.size())
        fail(where + ": bufferView " + std::to_string(a.bufferView) + " refers to buffer " +
             std::to_string(bv.buffer) + ", which does not exist");
    const tinygltf::Buffer &buf = model.buffers[size_t(bv.buffer)];
    if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset)
        fail(where + " is out of bounds: bufferView " + std::to_string(a.bufferView) + " spans bytes " +
             std::to_string(bv.byteOffset) + " + " + std::to_string(bv.byteLength) + " of buffer " +
             std::to_string(bv.buffer) + ", which has " + std::to_string(buf.data.size()) + " bytes");
    v.stride = bv.byteStride ? bv.byteStride : elem;
    if (v.stride < elem)
        fail(where + ": bufferView byteStride " + std::to_string(v.stride) +
             " is smaller than the element size " + std::to_string(elem));
    if (v.count > 0) {
        // (count - 1) * stride + elem <= byteLength - byteOffset, written to avoid overflow.
        bool fits = a.byteOffset <= bv.byteLength && elem <= bv.byteLength - a.byteOffset &&
                    (v.count - 1) <= (bv.byteLength - a.byteOffset - elem) / v.stride;
        if (!fits)
            fail(where + " is out of bounds: " + std::to_string(v.count) + " elements of " +
                 std::to_string(elem) + " bytes at byteOffset " + std::to_string(a.byteOffset) +
                 " with stride " + std::to_string(v.stride) + " do not fit bufferView " +
                 std::to_string(a.bufferView) + " of " + std::to_string(bv.byteLength) + " bytes");
    }
    v.base = buf.data.data() + bv.byteOffset + a.byteOffset;
    return v;
}

// Component k of element i as a double; normalised integers map to [0, 1] (or [-1, 1]).
double read_component(const accessor_view &v, size_t i, int k)
{
    if (!v.base)
        return 0.0;
    const unsigned char *p = v.base + i * v.stride + size_t(k) * component_size(v.component_type);
    // memcpy: glTF only guarantees component alignment, and only for conforming files.
    switch (v.component_type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f;
        std::memcpy(&f, p, 4);
        return f;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return v.normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
        double x = int8_t(p[0]);
        return v.normalized ? std::fmax(x / 127.0, -1.0) : x;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t x;
        std::memcpy(&x, p, 2);
        return v.normalized ? x / 65535.0 : x;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t x;
        std::memcpy(&x, p, 2);
        return v.normalized ? std::fmax(x / 32767.0, -1.0) : x;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t x;
        std::memcpy(&x, p, 4);
        return x;
    }
    default: return 0.0;
    }
}

struct loader {
    const tinygltf::Model &model;
    mesh *out;
    uint32_t material;
    gltf_material_fn make_material; // NULL: base colours become vertex colours
    void *material_ctx;
    bool to_subdivide;              // a primitive without NORMAL keeps shared vertices (see add_primitive)
    std::vector<int64_t> made;      // voxlab material per glTF material, -1 until made
    size_t triangle_primitives = 0, other_primitives = 0;

    // The voxlab material of glTF material m (made once): its base colour factor and texture.
    uint32_t own_material(int m)
    {
        if (made.empty())
            made.assign(model.materials.size(), -1);
        if (made[size_t(m)] >= 0)
            return uint32_t(made[size_t(m)]);
        const tinygltf::Material &mat = model.materials[size_t(m)];
        gltf_material_desc d{};
        d.name = mat.name.c_str();
        const std::vector<double> &f = mat.pbrMetallicRoughness.baseColorFactor;
        for (int k = 0; k < 4; k++) {
            d.base_color[k] = f.size() > size_t(k) ? f[size_t(k)] : 1.0;
            if (!(d.base_color[k] >= 0.0 && d.base_color[k] <= 1.0))
                fail("material " + std::to_string(m) + ": baseColorFactor[" + std::to_string(k) + "] is " +
                     std::to_string(d.base_color[k]) + " (expected 0..1)");
        }
        const tinygltf::TextureInfo &ti = mat.pbrMetallicRoughness.baseColorTexture;
        if (ti.index >= 0) {
            if (size_t(ti.index) >= model.textures.size())
                fail("material " + std::to_string(m) + ": baseColorTexture refers to texture " +
                     std::to_string(ti.index) + ", which does not exist");
            int src = model.textures[size_t(ti.index)].source;
            if (src < 0 || size_t(src) >= model.images.size())
                fail("texture " + std::to_string(ti.index) + " has no image (source " + std::to_string(src) + ")");
            if (ti.texCoord != 0)
                fail("material " + std::to_string(m) + ": baseColorTexture reads TEXCOORD_" +
                     std::to_string(ti.texCoord) + " (only TEXCOORD_0 is read)");
            const tinygltf::Image &img = model.images[size_t(src)];
            if (img.bits != 8 || img.component < 1 || img.component > 4 || img.width < 1 || img.height < 1 ||
                img.image.size() != size_t(img.width) * size_t(img.height) * size_t(img.component))
                fail("image " + std::to_string(src) + " of material " + std::to_string(m) +
                     " did not decode to 8-bit texels (expected a PNG or JPEG)");
            d.texels = img.image.data();
            d.width = img.width, d.height = img.height, d.components = img.component;
        }
        uint32_t out_index;
        vx_err e;
        if (make_material(material_ctx, m, &d, &out_index, &e))
            fail(std::string("material ") + std::to_string(m) + ": " + e.msg);
        made[size_t(m)] = out_index;
        return out_index;
    }

    // Requires the accessor to hold `components`-vectors of float (or, when allow_normalized, of
    // normalised unsigned bytes/shorts, which glTF permits for texture coordinates and colours).
    accessor_view attribute(const tinygltf::Primitive &prim, const char *name, const std::string &prim_name,
                            int min_components, int max_components, bool allow_normalized, size_t count)
    {
        auto it = prim.attributes.find(name);
        if (it == prim.attributes.end())
            return accessor_view{};
        std::string what = std::string(name) + " of " + prim_name;
        accessor_view v = resolve_accessor(model, it->second, what);
        bool type_ok = v.component_type == TINYGLTF_COMPONENT_TYPE_FLOAT ||
                       (allow_normalized && v.normalized &&
                        (v.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                         v.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT));
        if (!type_ok || v.components < min_components || v.components > max_components)
            fail("accessor " + std::to_string(it->second) + " (" + what + ") holds " +
                 std::to_string(v.components) + "-component " + component_name(v.component_type) +
                 " values (expected " +
                 (min_components == max_components ? "VEC" + std::to_string(min_components)
                                                   : "VEC" + std::to_string(min_components) + " or VEC" +
                                                         std::to_string(max_components)) +
                 (allow_normalized ? " of float or normalised unsigned byte/short)" : " of float)"));
        if (v.count != count)
            fail("accessor " + std::to_string(it->second) + " (" + what + ") has " +
                 std::to_string(v.count) + " elements but POSITION has " + std::to_string(count));
        return v;
    }

    void add_primitive(const tinygltf::Primitive &prim, const std::string &prim_name, const mat4 &m)
    {
        auto pos_it = prim.attributes.find("POSITION");
        if (pos_it == prim.attributes.end())
            fail(prim_name + " has no POSITION attribute");
        accessor_view pos = resolve_accessor(model, pos_it->second, "POSITION of " + prim_name);
        if (pos.component_type != TINYGLTF_COMPONENT_TYPE_FLOAT || pos.components != 3)
            fail("accessor " + std::to_string(pos_it->second) + " (POSITION of " + prim_name + ") holds " +
                 std::to_string(pos.components) + "-component " + component_name(pos.component_type) +
                 " values (expected VEC3 of float)");
        accessor_view nrm = attribute(prim, "NORMAL", prim_name, 3, 3, false, pos.count);
        accessor_view uv = attribute(prim, "TEXCOORD_0", prim_name, 2, 2, true, pos.count);
        accessor_view col = attribute(prim, "COLOR_0", prim_name, 3, 4, true, pos.count);
        bool has_normals = prim.attributes.count("NORMAL") != 0;
        bool has_uvs = prim.attributes.count("TEXCOORD_0") != 0;
        bool has_colors = prim.attributes.count("COLOR_0") != 0;

        double base_color[3] = {1.0, 1.0, 1.0};
        uint32_t material = this->material;
        if (prim.material >= 0 && make_material) {
            if (size_t(prim.material) >= model.materials.size())
                fail(prim_name + " refers to material " + std::to_string(prim.material) + ", which does not exist");
            material = own_material(prim.material);
        } else if (prim.material >= 0) {
            if (size_t(prim.material) >= model.materials.size())
                fail(prim_name + " refers to material " + std::to_string(prim.material) +
                     ", which does not exist");
            const std::vector<double> &f = model.materials[size_t(prim.material)].pbrMetallicRoughness.baseColorFactor;
            if (f.size() >= 3)
                for (int k = 0; k < 3; k++)
                    base_color[k] = f[size_t(k)];
        }

        // Normals transform by the inverse transpose of the linear part; the cofactor matrix is that
        // times det, so it serves once the sign of det is restored (the length is renormalised).
        double a[9]; // row-major 3x3 linear part
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                a[r * 3 + c] = m[c * 4 + r];
        double cof[9] = {a[4] * a[8] - a[5] * a[7], a[5] * a[6] - a[3] * a[8], a[3] * a[7] - a[4] * a[6],
                         a[2] * a[7] - a[1] * a[8], a[0] * a[8] - a[2] * a[6], a[1] * a[6] - a[0] * a[7],
                         a[1] * a[5] - a[2] * a[4], a[2] * a[3] - a[0] * a[5], a[0] * a[4] - a[1] * a[3]};
        double det = a[0] * cof[0] + a[1] * cof[1] + a[2] * cof[2];
        double sign = det < 0.0 ? -1.0 : 1.0;

        size_t v0 = out->vertex_count, t0 = out->triangle_count;
        if (pos.count > size_t(UINT32_MAX) - v0)
            fail(prim_name + ": " + std::to_string(pos.count) + " vertices do not fit 32-bit indices");
        for (size_t i = 0; i < pos.count; i++) {
            double p[3] = {read_component(pos, i, 0), read_component(pos, i, 1), read_component(pos, i, 2)};
            float w[3];
            for (int r = 0; r < 3; r++)
                w[r] = float(m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
            if (!std::isfinite(w[0]) || !std::isfinite(w[1]) || !std::isfinite(w[2]))
                fail(prim_name + ": vertex " + std::to_string(i) + " has a non-finite position");
            vec3 n = v3(0.0f, 0.0f, 1.0f);
            if (has_normals) {
                double ln[3] = {read_component(nrm, i, 0), read_component(nrm, i, 1), read_component(nrm, i, 2)};
                double wn[3];
                for (int r = 0; r < 3; r++)
                    wn[r] = sign * (cof[r * 3] * ln[0] + cof[r * 3 + 1] * ln[1] + cof[r * 3 + 2] * ln[2]);
                if (!std::isfinite(wn[0]) || !std::isfinite(wn[1]) || !std::isfinite(wn[2]))
                    fail(prim_name + ": vertex " + std::to_string(i) + " has a non-finite normal");
                double len = std::sqrt(wn[0] * wn[0] + wn[1] * wn[1] + wn[2] * wn[2]);
                // A zero normal stays zero: the shading takes the face's geometric normal (rt_shade).
                n = len > 0.0 ? v3(float(wn[0] / len), float(wn[1] / len), float(wn[2] / len)) : v3(0.0f, 0.0f, 0.0f);
            }
            float u = has_uvs ? float(read_component(uv, i, 0)) : 0.0f;
            float t = has_uvs ? float(read_component(uv, i, 1)) : 0.0f;
            if (!std::isfinite(u) || !std::isfinite(t)) // a NaN texel lookup would make NaN pixels
                fail(prim_name + ": TEXCOORD_0 of vertex " + std::to_string(i) + " is not finite");
            uint32_t vi = mesh_add_vertex(out, v3(w[0], w[1], w[2]), n, u, t);
            double c[3] = {base_color[0], base_color[1], base_color[2]};
            if (has_colors)
                for (int k = 0; k < 3; k++) {
                    // An albedo factor (scene.c's parse_albedo says why): a float accessor may hold anything.
                    double ck = read_component(col, i, k);
                    if (!(ck >= 0.0 && ck <= 1.0))
                        fail(prim_name + ": COLOR_0 of vertex " + std::to_string(i) + " is " + std::to_string(ck) +
                             " (expected 0..1, an albedo)");
                    c[k] *= ck; // glTF: COLOR_0 multiplies the base colour
                }
            mesh_set_vertex_color(out, vi, v3(float(c[0]), float(c[1]), float(c[2])));
        }

        // A mirroring transform (det < 0) turns counter-clockwise into clockwise; glTF says the
        // front face flips with it, so the winding is swapped to keep counter-clockwise = front.
        bool flip = det < 0.0;
        uint32_t base = uint32_t(v0);
        auto add = [&](size_t i0, size_t i1, size_t i2) {
            if (flip)
                mesh_add_triangle(out, base + uint32_t(i0), base + uint32_t(i2), base + uint32_t(i1), material);
            else
                mesh_add_triangle(out, base + uint32_t(i0), base + uint32_t(i1), base + uint32_t(i2), material);
        };
        if (prim.indices >= 0) {
            std::string what = "indices of " + prim_name;
            accessor_view idx = resolve_accessor(model, prim.indices, what);
            bool ok = idx.components == 1 && (idx.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                              idx.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ||
                                              idx.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
            if (!ok)
                fail("accessor " + std::to_string(prim.indices) + " (" + what + ") holds " +
                     std::to_string(idx.components) + "-component " + component_name(idx.component_type) +
                     " values (expected SCALAR unsigned byte, short or int)");
            if (idx.count % 3 != 0)
                fail("accessor " + std::to_string(prim.indices) + " (" + what + ") has " +
                     std::to_string(idx.count) + " indices (expected a multiple of 3 for triangles)");
            for (size_t t = 0; t < idx.count; t += 3) {
                size_t i[3];
                for (int k = 0; k < 3; k++) {
                    double x = read_component(idx, t + size_t(k), 0);
                    if (!(x < double(pos.count)))
                        fail(what + ": index " + std::to_string(t + size_t(k)) + " is " +
                             std::to_string(size_t(x)) + ", out of range (POSITION has " +
                             std::to_string(pos.count) + " vertices)");
                    i[k] = size_t(x);
                }
                add(i[0], i[1], i[2]);
            }
        } else {
            if (pos.count % 3 != 0)
                fail(prim_name + " has no indices and " + std::to_string(pos.count) +
                     " vertices (expected a multiple of 3 for triangles)");
            for (size_t t = 0; t < pos.count; t += 3)
                add(t, t + 1, t + 2);
        }
        // Without NORMAL glTF 2.0 asks for flat normals: each triangle gets its own corners. An object
        // to be subdivided keeps the shared vertices (Loop subdivision connects by vertex index,
        // and would tear a split surface into separate pieces) and smooth ones, which the
        // subdivision recomputes from the refined surface anyway.
        if (!has_normals && to_subdivide) {
            mesh_smooth_normals(out, v0, t0);
        } else if (!has_normals) {
            size_t triangles = out->triangle_count - t0;
            if (triangles > (size_t(UINT32_MAX) - v0) / 3)
                fail(prim_name + ": " + std::to_string(triangles) + " triangles without NORMAL make " +
                     std::to_string(3 * triangles) + " flat-shaded vertices, which do not fit 32-bit indices");
            mesh_flat_normals(out, v0, t0);
        }
    }

    void walk(int node_index, const mat4 &parent, std::vector<char> &on_path)
    {
        if (node_index < 0 || size_t(node_index) >= model.nodes.size())
            fail("node " + std::to_string(node_index) + " does not exist (the file has " +
                 std::to_string(model.nodes.size()) + " nodes)");
        // A node that is its own ancestor would recurse forever; glTF forbids it, tinygltf lets it by.
        if (on_path[size_t(node_index)])
            fail("node " + std::to_string(node_index) + " is its own ancestor (the node hierarchy "
                 "must be a tree)");
        on_path[size_t(node_index)] = 1;
        const tinygltf::Node &node = model.nodes[size_t(node_index)];
        mat4 m = mul(parent, node_local(node, "node " + std::to_string(node_index)));
        if (node.mesh >= 0) {
            if (size_t(node.mesh) >= model.meshes.size())
                fail("node " + std::to_string(node_index) + " refers to mesh " + std::to_string(node.mesh) +
                     ", which does not exist");
            const tinygltf::Mesh &me = model.meshes[size_t(node.mesh)];
            for (size_t p = 0; p < me.primitives.size(); p++) {
                const tinygltf::Primitive &prim = me.primitives[p];
                // tinygltf fills in the spec's default (4) when "mode" is absent; -1 means the same.
                int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
                if (mode != TINYGLTF_MODE_TRIANGLES) {
                    other_primitives++;
                    continue;
                }
                triangle_primitives++;
                add_primitive(prim, "mesh " + std::to_string(node.mesh) + " primitive " + std::to_string(p), m);
            }
        }
        for (int child : node.children)
            walk(child, m, on_path);
        on_path[size_t(node_index)] = 0;
    }
};

// Images are never used (appearance comes from the material and vertex colours), so decoding them
// would only cost time and fail on textures we do not need.
bool skip_image(tinygltf::Image *, const int, std::string *, std::string *, int, int,
                const unsigned char *, int, void *)
{
    return true;
}

// Decodes an image for a material's baseColorTexture through tinygltf's own decoder (stb_image),
// after reading its size from the header alone: a small file declaring a huge image is refused
// before anything is allocated, as image_read does (IMAGE_MAX_PIXELS).

// Whether a PNG's chunks (length, type, data, CRC) all lie inside its `size` bytes up to IEND:
// Debian's stb_image copies a chunk's declared length without checking it against the buffer
// (fuzz_gltf: an IDAT of 18 bytes at the end of a truncated image, read past the buffer).
bool png_chunks_fit(const unsigned char *bytes, int size)
{
    long long at = 8;
    while (at + 12 <= size) {
        unsigned long long len = (unsigned long long)bytes[at] << 24 | (unsigned long long)bytes[at + 1] << 16 |
                                 (unsigned long long)bytes[at + 2] << 8 | bytes[at + 3];
        if ((unsigned long long)at + 12 + len > (unsigned long long)size)
            return false;
        if (std::memcmp(bytes + at + 4, "IEND", 4) == 0)
            return true;
        at += 12 + (long long)len;
    }
    return false;
}

bool bounded_image(tinygltf::Image *image, const int index, std::string *err, std::string *warn, int req_width,
                   int req_height, const unsigned char *bytes, int size, void *user)
{
    int w = 0, h = 0, comp = 0;
    /* PNG and JPEG only, by their signatures (the glTF spec's two; stb_image would also sniff TGA,
     * BMP, PSD, GIF, HDR, PIC and PNM, more decoders for a crafted file to reach), and a PNG's
     * chunks must fit in the buffer (png_chunks_fit). */
    static const unsigned char png[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'}, jpeg[3] = {0xff, 0xd8, 0xff};
    bool is_png = size >= 8 && std::memcmp(bytes, png, 8) == 0;
    bool known = (is_png && png_chunks_fit(bytes, size)) || (size >= 3 && std::memcmp(bytes, jpeg, 3) == 0);
    if (!known || !stbi_info_from_memory(bytes, size, &w, &h, &comp)) {
        if (err)
            *err += "image " + std::to_string(index) + " is not a PNG or JPEG this loader decodes\n";
        return false;
    }
    if (w < 1 || h < 1 || (long long)w * (long long)h > IMAGE_MAX_PIXELS) {
        if (err)
            *err += "image " + std::to_string(index) + " is " + std::to_string(w) + "x" + std::to_string(h) +
                    " pixels (at most " + std::to_string(IMAGE_MAX_PIXELS) + ")\n";
        return false;
    }
    return tinygltf::LoadImageData(image, index, err, warn, req_width, req_height, bytes, size, user);
}

bool ends_with_nocase(const std::string &s, const char *suffix)
{
    size_t n = std::strlen(suffix);
    if (s.size() < n)
        return false;
    for (size_t i = 0; i < n; i++) {
        char a = s[s.size() - n + i], b = suffix[i];
        if (a >= 'A' && a <= 'Z')
            a = char(a - 'A' + 'a');
        if (a != b)
            return false;
    }
    return true;
}

// External files a glTF names (buffer URIs) are read only from inside the glTF's own folder: a URI
// such as "../../etc/passwd" must not make a scene read, and echo facts about, any file on the
// machine. The folder is compared by real path, so symbolic links cannot lead out of it either.
struct uri_fs {
    std::string folder; // realpath of the glTF's folder, with a trailing '/'
    std::string refused; // the first URI refused, for the message
    bool anywhere = false; // the scene allows URIs outside the folder
    std::vector<std::string> read; // the external files read (buffers, images), each once
};

bool inside(const uri_fs &fs, const std::string &file)
{
    if (fs.anywhere)
        return true;
    char *real = realpath(file.c_str(), nullptr);
    if (!real)
        return false;
    bool ok = std::strncmp(real, fs.folder.c_str(), fs.folder.size()) == 0;
    std::free(real);
    return ok;
}

bool fs_exists(const std::string &file, void *user)
{
    auto *fs = static_cast<uri_fs *>(user);
    if (access(file.c_str(), F_OK) != 0)
        return false;
    if (!inside(*fs, file)) {
        if (fs->refused.empty())
            fs->refused = file;
        return false;
    }
    return true;
}

std::string fs_expand(const std::string &file, void *) { return file; } // no ~ or $VAR expansion

bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &file, void *user)
{
    auto *fs = static_cast<uri_fs *>(user);
    if (!inside(*fs, file)) {
        if (err)
            *err += file + " is outside the glTF's folder\n";
        return false;
    }
    vx_err e;
    size_t size = 0;
    char *buf = readfile_all(file.c_str(), "glTF buffer", READFILE_MAX_BYTES, &size, &e);
    if (!buf) {
        if (err)
            *err += std::string(e.msg) + "\n";
        return false;
    }
    out->assign(buf, buf + size);
    std::free(buf);
    if (std::find(fs->read.begin(), fs->read.end(), file) == fs->read.end())
        fs->read.push_back(file);
    return true;
}

bool fs_write(std::string *, const std::string &, const std::vector<unsigned char> &, void *) { return false; }

// The file's JSON (a .glb's JSON chunk), read before tinygltf reads it:
//  - glTF 1.0 (a different format: techniques, shaders, named objects) is refused by its version
//    rather than left to fail somewhere inside the 2.0 parser: the GLB header's version word, or
//    the JSON's asset.version;
//  - the scene file's rule (json_util.h): a key given twice in an object is refused (tinygltf's
//    JSON reader keeps one of the values without a word; glTF 2.0 requires unique keys), and so is
//    text after the document.
// JSON that cJSON cannot parse at all is left to tinygltf, whose message says what is wrong.
void check_json(const char *text, size_t size, bool binary, const std::string &file)
{
    std::string version, json, where = file;
    if (binary) {
        if (size < 8 || std::memcmp(text, "glTF", 4) != 0)
            return;
        uint32_t v, length, type;
        std::memcpy(&v, text + 4, 4);
        version = std::to_string(v);
        if (version[0] != '1' && size >= 20) {
            std::memcpy(&length, text + 12, 4);
            std::memcpy(&type, text + 16, 4);
            if (type == 0x4E4F534Au && length <= size - 20) // "JSON", the first chunk
                json.assign(text + 20, length);
            where += ": JSON chunk";
        }
    } else {
        json.assign(text, size);
    }
    const char *end = nullptr;
    cJSON *root = json.empty() ? nullptr : cJSON_ParseWithOpts(json.c_str(), &end, 0);
    if (root && !binary) {
        const cJSON *asset = cJSON_GetObjectItemCaseSensitive(root, "asset");
        const cJSON *v = asset ? cJSON_GetObjectItemCaseSensitive(asset, "version") : nullptr;
        if (cJSON_IsString(v) && v->valuestring)
            version = v->valuestring;
    }
    vx_err e;
    bool bad = root && (json_nothing_after(json.c_str(), end, where.c_str(), &e) ||
                        json_unique_keys(root, where.c_str(), &e));
    cJSON_Delete(root);
    if (!version.empty() && version[0] == '1')
        throw load_error{"asset version " + version + ": glTF 1.0 is not supported (expected glTF 2.0)"};
    if (bad)
        throw load_error{std::string(e.msg).substr(file.size() + 2)}; // mesh_load_gltf prefixes the path
}

// Every embedded image's bufferView lies inside its buffer's bytes (see load).
void check_image_ranges(const tinygltf::Model &m)
{
    for (size_t i = 0; i < m.images.size(); i++) {
        int v = m.images[i].bufferView;
        if (v < 0)
            continue; // a URI: tinygltf read the whole file and passes its true size
        if (size_t(v) >= m.bufferViews.size())
            fail("image " + std::to_string(i) + " names bufferView " + std::to_string(v) + " of " +
                 std::to_string(m.bufferViews.size()));
        const tinygltf::BufferView &bv = m.bufferViews[size_t(v)];
        if (bv.buffer < 0 || size_t(bv.buffer) >= m.buffers.size())
            fail("bufferView " + std::to_string(v) + " (image " + std::to_string(i) + ") names buffer " +
                 std::to_string(bv.buffer) + " of " + std::to_string(m.buffers.size()));
        size_t have = m.buffers[size_t(bv.buffer)].data.size();
        if (bv.byteOffset > have || bv.byteLength > have - bv.byteOffset)
            fail("bufferView " + std::to_string(v) + " (image " + std::to_string(i) + ") spans bytes " +
                 std::to_string(bv.byteOffset) + ".." + std::to_string(bv.byteOffset + bv.byteLength) + " of buffer " +
                 std::to_string(bv.buffer) + ", which holds " + std::to_string(have));
    }
}

void load(const char *path, mesh *out, uint32_t material, bool uris_anywhere, bool to_subdivide,
          gltf_material_fn make_material, void *material_ctx, gltf_file_fn on_file, void *file_ctx)
{
    std::string file(path);
    bool binary;
    if (ends_with_nocase(file, ".gltf"))
        binary = false;
    else if (ends_with_nocase(file, ".glb"))
        binary = true;
    else
        fail("unknown glTF file extension (expected .gltf or .glb)");

    tinygltf::Model model;
    tinygltf::TinyGLTF ctx;
    if (make_material)
        ctx.SetImageLoader(bounded_image, nullptr);
    else
        ctx.SetImageLoader(skip_image, nullptr);
    std::string err, warn;
    // The file itself through readfile_all (a regular file only: not a directory, FIFO or device).
    vx_err re;
    size_t size = 0;
    char *text = readfile_all(path, binary ? "glTF binary" : "glTF file", READFILE_MAX_BYTES, &size, &re);
    if (!text)
        throw load_error{std::string(re.msg).substr(file.size() + 2)}; // mesh_load_gltf prefixes the path
    try {
        check_json(text, size, binary, file);
    } catch (...) {
        std::free(text);
        throw;
    }
    std::string dir = file.find('/') == std::string::npos ? "." : file.substr(0, file.rfind('/') + 1);
    if (dir.empty())
        dir = "/";
    uri_fs fs;
    fs.anywhere = uris_anywhere;
    if (char *real = realpath(dir.c_str(), nullptr)) {
        fs.folder = real;
        std::free(real);
        if (fs.folder.back() != '/')
            fs.folder += '/';
    }
    ctx.SetFsCallbacks(tinygltf::FsCallbacks{fs_exists, fs_expand, fs_read, fs_write, &fs});
    bool ok;
    try {
        if (make_material) {
            // tinygltf hands an embedded image to the decoder as its bufferView's range without
            // checking that range against the buffer's bytes (a crafted file read past the buffer:
            // fuzz_gltf). A first parse without decoding lets us check every image's range first.
            tinygltf::Model plain;
            tinygltf::TinyGLTF pre;
            pre.SetImageLoader(skip_image, nullptr);
            pre.SetFsCallbacks(tinygltf::FsCallbacks{fs_exists, fs_expand, fs_read, fs_write, &fs});
            std::string e0, w0;
            if (binary ? pre.LoadBinaryFromMemory(&plain, &e0, &w0, reinterpret_cast<unsigned char *>(text),
                                                  unsigned(size), dir)
                       : pre.LoadASCIIFromString(&plain, &e0, &w0, text, unsigned(size), dir))
                check_image_ranges(plain);
        }
        ok = binary ? ctx.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<unsigned char *>(text),
                                               unsigned(size), dir)
                    : ctx.LoadASCIIFromString(&model, &err, &warn, text, unsigned(size), dir);
    } catch (...) {
        std::free(text);
        throw;
    }
    std::free(text);
    if (!ok && !fs.refused.empty())
        fail("buffer URI " + fs.refused + " lies outside the glTF's folder " + fs.folder +
             " (external files must be inside it, unless the scene's object says \"uris_outside_folder\": true)");
    if (!ok) {
        std::string msg = "tinygltf could not load the file: " + trimmed(err);
        if (!trimmed(warn).empty())
            msg += " (warnings: " + trimmed(warn) + ")";
        fail(msg);
    }
    // Compressed geometry leaves the accessors without data (tinygltf is built without Draco and
    // meshopt), which would load as a heap of zero-area triangles rather than fail.
    for (const std::string &ext : model.extensionsRequired)
        if (ext == "KHR_draco_mesh_compression" || ext == "EXT_meshopt_compression" ||
            ext == "KHR_meshopt_compression")
            fail("requires extension " + ext + " (compressed geometry is not supported; expected plain "
                 "accessors)");

    // The external files the load read, for the caller's list of inputs (an output must not
    // overwrite a glTF's texture or buffer any more than the glTF itself).
    for (const std::string &f : fs.read)
        if (on_file && on_file(file_ctx, f.c_str()))
            fail("out of memory for the list of the files the glTF names");

    loader l{model, out, material, make_material, material_ctx, to_subdivide, {}};
    std::vector<char> on_path(model.nodes.size(), 0);
    if (!model.scenes.empty()) {
        size_t s = model.defaultScene >= 0 && size_t(model.defaultScene) < model.scenes.size()
                       ? size_t(model.defaultScene)
                       : 0;
        for (int n : model.scenes[s].nodes)
            l.walk(n, identity(), on_path);
    } else {
        // No scene: every root node (one that is nobody's child) stands for the model.
        std::vector<char> is_child(model.nodes.size(), 0);
        for (const tinygltf::Node &n : model.nodes)
            for (int c : n.children)
                if (c >= 0 && size_t(c) < is_child.size())
                    is_child[size_t(c)] = 1;
        for (size_t n = 0; n < model.nodes.size(); n++)
            if (!is_child[n])
                l.walk(int(n), identity(), on_path);
    }
    if (l.triangle_primitives == 0)
        fail("no triangle primitives (glTF mode 4) in the scene's nodes; " +
             std::to_string(l.other_primitives) + " primitives of other modes were skipped");
}

} // namespace

extern "C" int mesh_load_gltf(const char *path, mesh *out, uint32_t material, vx_err *e)
{
    return mesh_load_gltf_materials(path, out, material, 0, nullptr, nullptr, e);
}

extern "C" int mesh_load_gltf_uris(const char *path, mesh *out, uint32_t material, int uris_anywhere, vx_err *e)
{
    return mesh_load_gltf_materials(path, out, material, uris_anywhere, nullptr, nullptr, e);
}

extern "C" int mesh_load_gltf_materials(const char *path, mesh *out, uint32_t material, int uris_anywhere,
                                        gltf_material_fn make_material, void *ctx, vx_err *e)
{
    return mesh_load_gltf_files(path, out, material, uris_anywhere, 0, make_material, ctx, nullptr, nullptr, e);
}

extern "C" int mesh_load_gltf_files(const char *path, mesh *out, uint32_t material, int uris_anywhere,
                                    int to_subdivide, gltf_material_fn make_material, void *ctx, gltf_file_fn on_file,
                                    void *file_ctx, vx_err *e)
{
    return vx_mesh_load::guarded(path, out, "glTF", [&] {
        load(path, out, material, uris_anywhere != 0, to_subdivide != 0, make_material, ctx, on_file, file_ctx);
    }, e);
}
