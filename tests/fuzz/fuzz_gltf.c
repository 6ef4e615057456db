/* libFuzzer harness: the glTF 2.0 loader, JSON (.gltf) or binary (.glb, chosen when the input starts
 * with the GLB magic "glTF"), with its own materials: their base colours and textures (images
 * decoded, size-bounded) handed to a callback as the scene loader's is. Buffer URIs may name the
 * fixtures beside the file. */
#include "fuzz_common.h"
#include "mesh.h"
#include "mesh_load.h"

/* Touches every texel the loader hands over (so that a wrong size is a read out of bounds under
 * ASan) and gives every glTF material voxlab material 0. */
static int material(void *ctx, int index, const gltf_material_desc *d, uint32_t *out, vx_err *e)
{
    (void)index, (void)e;
    unsigned *sum = ctx;
    if (d->texels)
        for (size_t i = 0; i < (size_t)d->width * (size_t)d->height * (size_t)d->components; i++)
            *sum += d->texels[i];
    *out = 0;
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    int glb = size >= 4 && memcmp(data, "glTF", 4) == 0;
    const char *path = fuzz_write(glb ? "mesh.glb" : "mesh.gltf", data, size);
    mesh m;
    memset(&m, 0, sizeof m);
    vx_err e;
    unsigned sum = 0;
    mesh_load_gltf_materials(path, &m, 0, 0, material, &sum, &e);
    mesh_free(&m);
    return 0;
}
