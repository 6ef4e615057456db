// What the C++ mesh readers (mesh_gltf.cpp, mesh_obj.cpp) share behind mesh_load.h's C functions:
// errors thrown as load_error and turned into the vx_err message by one guard, which also leaves
// the caller's mesh as it was when a load fails.
#ifndef VX_MESH_LOAD_CPP_H
#define VX_MESH_LOAD_CPP_H

#include <exception>
#include <string>

#include "mesh_load.h"

namespace vx_mesh_load {

struct load_error {
    std::string msg;
};

[[noreturn]] inline void fail(const std::string &msg) { throw load_error{msg}; }

// A library's message without its trailing newlines and spaces.
inline std::string trimmed(std::string s)
{
    while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' '))
        s.pop_back();
    return s;
}

// Runs load(); any exception becomes "PATH: message" in e (format names the reader in messages for
// exceptions other than load_error), and a failed load takes back the vertices and triangles it
// added: a failed load must not leave half a model behind.
template <class Load> int guarded(const char *path, mesh *out, const char *format, Load load, vx_err *e)
{
    size_t v0 = out->vertex_count, t0 = out->triangle_count;
    int rc = 0;
    try {
        load();
    } catch (const load_error &err) {
        rc = vx_fail(e, "%s: %s", path, err.msg.c_str());
    } catch (const std::exception &ex) {
        rc = vx_fail(e, "%s: %s loading failed (%s)", path, format, ex.what());
    } catch (...) {
        rc = vx_fail(e, "%s: %s loading failed (unknown C++ exception)", path, format);
    }
    if (rc != 0) {
        out->vertex_count = v0;
        out->triangle_count = t0;
    }
    return rc;
}

} // namespace vx_mesh_load

#endif
