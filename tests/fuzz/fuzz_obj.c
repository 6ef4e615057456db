/* libFuzzer harness: the OBJ reader (tinyobjloader behind mesh_load_obj). */
#include "fuzz_common.h"
#include "mesh.h"
#include "mesh_load.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_write("mesh.obj", data, size);
    mesh m;
    memset(&m, 0, sizeof m);
    vx_err e;
    mesh_load_obj(path, &m, 0, &e);
    mesh_free(&m);
    return 0;
}
