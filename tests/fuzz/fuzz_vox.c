/* libFuzzer harness: the .vox reader and record validation (vox_load), against a fixed small scene
 * (tests/fuzz/vox_scene.json). The checksum at the end of the input is recomputed first: it guards
 * against accidents only, and a crafted file carries a valid one, so what is fuzzed is everything
 * behind it. Records that pass their model's validation are then evaluated (opacity and shade for
 * a few directions) by voxel-marching models, so that a record the validation lets through cannot
 * make the evaluation misbehave. The grid is rebuilt from the file's cells (grid_build_sorted_cells),
 * so their checks are fuzzed too. Grid resolutions above 64 are skipped: a 1024^3 grid per input
 * would only slow the search, and the header's range check is tested elsewhere. */
#include "fuzz_common.h"
#include "grid.h"
#include "model.h"
#include "scene.h"
#include "vox_load.h"
#include "voxfile.h"

static scene fuzz_scene_;
static int have_scene;

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    const char *sp = getenv("VOXLAB_FUZZ_VOX_SCENE");
    vx_err e;
    if (!sp || scene_load(sp, &fuzz_scene_, &e) != 0) {
        fprintf(stderr, "fuzz_vox: set VOXLAB_FUZZ_VOX_SCENE to a loadable scene (%s)\n", sp ? e.msg : "unset");
        abort();
    }
    have_scene = 1;
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!have_scene || size < 8 + 8 + 64)
        return 0;
    uint8_t *copy = malloc(size);
    memcpy(copy, data, size);
    int32_t n;
    memcpy(&n, copy + 8 + 48, sizeof n); /* voxfile_header.n */
    if (n > 64) {
        free(copy);
        return 0;
    }
    uint64_t sum = voxfile_checksum(copy, size - 8);
    memcpy(copy + size - 8, &sum, sizeof sum);
    const char *path = fuzz_write("f.vox", copy, size);
    free(copy);
    const vx_model *m = NULL;
    voxel_grid g;
    void *records = NULL;
    voxfile_header h;
    double gs;
    vx_err e;
    if (vox_load(&fuzz_scene_, path, NULL, &m, &g, &records, &h, &gs, &e) != 0)
        return 0;
    if (m->voxel != NULL) {
        static const float dirs[3][3] = {{0, 0, 1}, {0.6f, 0.8f, 0}, {-0.577f, -0.577f, 0.577f}};
        for (size_t i = 0; i < grid_count(&g, 0); i++) {
            const void *r = (const unsigned char *)records + i * m->record.bytes;
            for (int d = 0; d < 3; d++) {
                vx_query q;
                memset(&q, 0, sizeof q);
                q.ray_dir = v3(dirs[d][0], dirs[d][1], dirs[d][2]);
                q.to_viewer = v3_scale(q.ray_dir, -1.0f);
                q.t1 = g.voxel_size;
                q.voxel_size = g.voxel_size;
                q.footprint = 0.1f * g.voxel_size;
                q.light_count = 1;
                q.to_light[0] = v3(0, 1, 0);
                q.irradiance[0] = v3(1, 1, 1);
                q.grid = &g;
                q.records = records;
                vx_answer a;
                memset(&a, 0, sizeof a);
                a.opacity = m->voxel->opacity.fn(r, &q);
                m->voxel->shade.fn(r, &q, &a);
            }
        }
    }
    free(records);
    grid_free(&g);
    return 0;
}
