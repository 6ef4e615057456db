/* libFuzzer harness: the glTF 2.0 loader, JSON (.gltf) or binary (.glb, chosen when the input starts
 * with the GLB magic "glTF"). Buffer URIs may name the fixtures beside the file. */
#include "fuzz_common.h"
#include "mesh.h"
#include "mesh_load.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    int glb = size >= 4 && memcmp(data, "glTF", 4) == 0;
    const char *path = fuzz_write(glb ? "mesh.glb" : "mesh.gltf", data, size);
    mesh m;
    memset(&m, 0, sizeof m);
    vx_err e;
    mesh_load_gltf(path, &m, 0, &e);
    mesh_free(&m);
    return 0;
}
