// Wavefront OBJ through Debian's tinyobjloader (a C++ library behind mesh_load.h's C function).
// The file is read with readfile_all (a regular file only, bounded) and parsed from memory, so a
// directory, FIFO or device named as an OBJ is refused, and its `mtllib` lines are ignored: the
// scene's material applies, as for PLY.
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <tuple>

#include <tiny_obj_loader.h>

#include "mesh_load.h"
#include "mesh_load_cpp.h"
#include "readfile.h"

namespace {

using vx_mesh_load::fail;
using vx_mesh_load::trimmed;

// "line N (\"the line\")", the line cut to 60 characters: a message, not a dump of a huge line.
std::string shown(size_t line, const std::string &text)
{
    std::string t = trimmed(text);
    return "line " + std::to_string(line) + " (\"" + (t.size() > 60 ? t.substr(0, 60) + "..." : t) + "\")";
}

// Every `v`, `vt` and `vn` line holds as many numbers as it must, each one a finite number.
// tinyobjloader reads a malformed or missing number as 0 and parses "nan" and "inf" as 0 too, so a
// corrupt file would render as a different, plausible mesh; its line is named here instead.
void check_numbers(const std::string &obj)
{
    size_t line = 0, at = 0;
    while (at < obj.size()) {
        size_t end = obj.find('\n', at);
        if (end == std::string::npos)
            end = obj.size();
        line++;
        std::string text = obj.substr(at, end - at);
        at = end + 1;
        const char *s = text.c_str();
        while (*s == ' ' || *s == '\t')
            s++;
        int least, most;
        if (std::strncmp(s, "v ", 2) == 0 || std::strncmp(s, "v\t", 2) == 0)
            least = 3, most = 7, s += 1; // x y z, then w or r g b
        else if (std::strncmp(s, "vt ", 3) == 0 || std::strncmp(s, "vt\t", 3) == 0)
            least = 1, most = 3, s += 2; // u [v [w]]
        else if (std::strncmp(s, "vn ", 3) == 0 || std::strncmp(s, "vn\t", 3) == 0)
            least = 3, most = 3, s += 2;
        else
            continue;
        int count = 0;
        for (;;) {
            while (*s == ' ' || *s == '\t' || *s == '\r')
                s++;
            if (!*s || *s == '#')
                break;
            char *stop = nullptr;
            double x = std::strtod(s, &stop);
            bool separated = stop != s && (!*stop || *stop == ' ' || *stop == '\t' || *stop == '\r' || *stop == '#');
            if (!separated || !std::isfinite(x)) {
                size_t len = std::strcspn(s, " \t\r#");
                fail(shown(line, text) + ": a malformed or non-finite number \"" +
                     std::string(s, len < 40 ? len : 40) + "\" (expected finite numbers)");
            }
            count++;
            s = stop;
        }
        if (count < least || count > most)
            fail(shown(line, text) + ": expected " + std::to_string(least) +
                 (least == most ? "" : " to " + std::to_string(most)) + " numbers, found " + std::to_string(count));
    }
}

void load(const char *path, mesh *out, uint32_t material)
{
    vx_err re;
    size_t size = 0;
    char *text = readfile_all(path, "OBJ file", READFILE_MAX_BYTES, &size, &re);
    if (!text)
        fail(std::string(re.msg).substr(std::string(path).size() + 2)); // the caller prefixes the path
    std::string obj(text, size);
    std::free(text);
    check_numbers(obj);
    tinyobj::ObjReaderConfig config;
    config.triangulate = true; // fans, as the PLY reader does
    config.vertex_color = false;
    tinyobj::ObjReader reader;
    if (!reader.ParseFromString(obj, std::string(), config))
        fail("tinyobjloader could not parse it: " + trimmed(reader.Error()));
    const tinyobj::attrib_t &a = reader.GetAttrib();
    size_t nv = a.vertices.size() / 3, nn = a.normals.size() / 3, nt = a.texcoords.size() / 2;
    size_t v0 = out->vertex_count, t0 = out->triangle_count;
    // A mesh vertex per distinct (position, normal, uv) triple of the file's face corners, so that
    // corners sharing all three share the vertex (and, without normals, its smooth normal).
    std::map<std::tuple<int, int, int>, uint32_t> shared;
    for (const tinyobj::shape_t &shape : reader.GetShapes()) {
        const tinyobj::mesh_t &m = shape.mesh;
        size_t at = 0;
        for (size_t f = 0; f < m.num_face_vertices.size(); f++) {
            if (m.num_face_vertices[f] != 3 || at + 3 > m.indices.size())
                fail("face " + std::to_string(f) + " of shape \"" + shape.name + "\" is not a triangle after triangulation");
            uint32_t idx[3];
            bool missing_normal = false;
            for (size_t k = 0; k < 3; k++) {
                const tinyobj::index_t &ix = m.indices[at + k];
                if (ix.vertex_index < 0 || size_t(ix.vertex_index) >= nv)
                    fail("face " + std::to_string(f) + " refers to vertex " + std::to_string(ix.vertex_index + 1) +
                         ", out of range (the file has " + std::to_string(nv) + ")");
                if (ix.normal_index >= 0 && size_t(ix.normal_index) >= nn)
                    fail("face " + std::to_string(f) + " refers to normal " + std::to_string(ix.normal_index + 1) +
                         ", out of range (the file has " + std::to_string(nn) + ")");
                if (ix.texcoord_index >= 0 && size_t(ix.texcoord_index) >= nt)
                    fail("face " + std::to_string(f) + " refers to texture coordinate " +
                         std::to_string(ix.texcoord_index + 1) + ", out of range (the file has " + std::to_string(nt) + ")");
                auto key = std::make_tuple(ix.vertex_index, ix.normal_index, ix.texcoord_index);
                auto found = shared.find(key);
                if (found != shared.end()) {
                    idx[k] = found->second;
                    continue;
                }
                const float *p = &a.vertices[3 * size_t(ix.vertex_index)];
                if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
                    fail("vertex " + std::to_string(ix.vertex_index + 1) + " has a non-finite coordinate");
                vec3 normal = v3(0.0f, 0.0f, 0.0f);
                if (ix.normal_index >= 0) {
                    const float *q = &a.normals[3 * size_t(ix.normal_index)];
                    if (!std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2]))
                        fail("normal " + std::to_string(ix.normal_index + 1) + " is not finite");
                    normal = v3_normalize_or(v3(q[0], q[1], q[2]), v3(0.0f, 0.0f, 0.0f));
                }
                missing_normal |= ix.normal_index < 0 && nn > 0;
                float u = 0.0f, v = 0.0f;
                if (ix.texcoord_index >= 0) {
                    u = a.texcoords[2 * size_t(ix.texcoord_index)];
                    v = a.texcoords[2 * size_t(ix.texcoord_index) + 1];
                    if (!std::isfinite(u) || !std::isfinite(v))
                        fail("texture coordinate " + std::to_string(ix.texcoord_index + 1) + " is not finite");
                }
                idx[k] = shared[key] = mesh_add_vertex(out, v3(p[0], p[1], p[2]), normal, u, v);
            }
            if (missing_normal) { // a corner without `vn` in a file that has normals: the face's own
                vec3 pa = mesh_position(out, idx[0]), pb = mesh_position(out, idx[1]), pc = mesh_position(out, idx[2]);
                vec3 fn = v3_normalize_or(v3_cross(v3_sub(pb, pa), v3_sub(pc, pa)), v3(0.0f, 0.0f, 1.0f));
                for (size_t k = 0; k < 3; k++)
                    if (m.indices[at + k].normal_index < 0)
                        out->normals[3 * idx[k]] = fn.x, out->normals[3 * idx[k] + 1] = fn.y, out->normals[3 * idx[k] + 2] = fn.z;
            }
            mesh_add_triangle(out, idx[0], idx[1], idx[2], material);
            at += 3;
        }
    }
    if (out->triangle_count == t0)
        fail("no faces (expected `f` lines)");
    if (nn == 0) // no normals in the file: smooth area-weighted ones, as for a PLY scan
        mesh_smooth_normals(out, v0, t0);
}

} // namespace

extern "C" int mesh_load_obj(const char *path, mesh *out, uint32_t material, vx_err *e)
{
    return vx_mesh_load::guarded(path, out, "OBJ", [&] { load(path, out, material); }, e);
}
