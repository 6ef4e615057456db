/* Tests of mesh_load_ply and mesh_load_gltf against the fixtures in tests/data (binary ones made by
 * tests/data/make_fixtures.py) and small malformed files written at run time. Runs from the repo
 * root, as tests/run_all.sh does. */
#include "mesh_load.h"
#include "unit.h"

#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

typedef int (*loader_fn)(const char *, mesh *, uint32_t, vx_err *);

static char tmp_dir[512];
static bool tmp_dir_is_ours; /* made by mkdtemp, so removed at the end */
static char tmp_files[64][1024];
static int tmp_file_count;

/* A scratch directory: $TEST_TMP when run_all.sh provides one, else a fresh one under /tmp. */
static void make_tmp_dir(void)
{
    const char *t = getenv("TEST_TMP");
    if (t && *t) {
        snprintf(tmp_dir, sizeof tmp_dir, "%s", t);
        mkdir(tmp_dir, 0777);
    } else {
        snprintf(tmp_dir, sizeof tmp_dir, "/tmp/voxlab_mesh_load_XXXXXX");
        if (!mkdtemp(tmp_dir))
            tmp_dir[0] = '\0';
        tmp_dir_is_ours = tmp_dir[0] != '\0';
    }
}

static void remove_tmp_files(void)
{
    for (int i = 0; i < tmp_file_count; i++)
        unlink(tmp_files[i]);
    if (tmp_dir_is_ours)
        rmdir(tmp_dir);
}

/* Writes n bytes to a file in the scratch directory and returns its path (static storage, reused). */
static const char *write_tmp_bytes(const char *name, const void *data, size_t n)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", tmp_dir, name);
    if (tmp_file_count < (int)(sizeof tmp_files / sizeof tmp_files[0]))
        snprintf(tmp_files[tmp_file_count++], sizeof tmp_files[0], "%s", path);
    FILE *f = fopen(path, "wb");
    if (f) {
        fwrite(data, 1, n, f);
        fclose(f);
    }
    return path;
}

/* The same for text. */
static const char *write_tmp(const char *name, const char *text)
{
    return write_tmp_bytes(name, text, strlen(text));
}

static bool near3(const float *v, float x, float y, float z, float tol)
{
    return fabsf(v[0] - x) <= tol && fabsf(v[1] - y) <= tol && fabsf(v[2] - z) <= tol;
}

/* Loading `path` must fail with -1, a message naming the file and containing `keyword`, and leave
 * the mesh (which already holds one triangle) as it was. */
static void expect_fail(const char *name, loader_fn load, const char *path, const char *keyword)
{
    mesh m = {0};
    mesh_add_flat_triangle(&m, v3(0, 0, 0), v3(1, 0, 0), v3(0, 1, 0), 0);
    vx_err e = {{0}};
    int rc = load(path, &m, 0, &e);
    char label[256];
    printf("# %s: %s\n", name, e.msg);
    snprintf(label, sizeof label, "%s returns -1", name);
    CHECK(label, rc == -1);
    snprintf(label, sizeof label, "%s message names the file", name);
    CHECK(label, strstr(e.msg, path) != NULL);
    snprintf(label, sizeof label, "%s message says '%s'", name, keyword);
    CHECK(label, strstr(e.msg, keyword) != NULL);
    snprintf(label, sizeof label, "%s leaves the mesh unchanged", name);
    CHECK(label, m.vertex_count == 3 && m.triangle_count == 1);
    mesh_free(&m);
}

static void test_ply_ascii(void)
{
    mesh m = {0};
    vx_err e = {{0}};
    int rc = mesh_load_ply("tests/data/quad_ascii.ply", &m, 7, &e);
    CHECK("ply ascii loads", rc == 0);
    if (rc) {
        printf("# %s\n", e.msg);
        return;
    }
    CHECK("ply ascii 5 vertices", m.vertex_count == 5);
    CHECK("ply ascii quad fans into 2 + 1 triangles", m.triangle_count == 3);
    static const uint32_t want[9] = {0, 1, 2, 0, 2, 3, 1, 4, 2};
    CHECK("ply ascii fan triangulation", memcmp(m.indices, want, sizeof want) == 0);
    CHECK("ply ascii material", m.materials[0] == 7 && m.materials[2] == 7);
    CHECK("ply ascii vertex 4 position", near3(&m.positions[12], 2, 0, 0, 0));
    bool normals_up = true, white = true;
    for (size_t i = 0; i < m.vertex_count; i++) {
        normals_up &= near3(&m.normals[3 * i], 0, 0, 1, 1e-6f);
        white &= near3(&m.colors[3 * i], 1, 1, 1, 0);
    }
    CHECK("ply ascii smooth normals face +z", normals_up);
    CHECK("ply ascii without colours stays white", white);
    mesh_free(&m);
}

static void test_ply_big_endian(void)
{
    mesh m = {0};
    /* Something already in the mesh: the file's indices must be offset past it. */
    mesh_add_flat_triangle(&m, v3(0, 0, 0), v3(1, 0, 0), v3(0, 1, 0), 0);
    vx_err e = {{0}};
    int rc = mesh_load_ply("tests/data/be_normals_colors.ply", &m, 2, &e);
    CHECK("ply big-endian loads", rc == 0);
    if (rc) {
        printf("# %s\n", e.msg);
        return;
    }
    CHECK("ply big-endian counts", m.vertex_count == 3 + 4 && m.triangle_count == 1 + 2);
    static const uint32_t want[6] = {3, 4, 5, 3, 5, 6};
    CHECK("ply big-endian indices offset by existing vertices", memcmp(&m.indices[3], want, sizeof want) == 0);
    CHECK("ply big-endian positions (float x, double y, float z)",
          near3(&m.positions[3 * 3], 0, 0, 1, 0) && near3(&m.positions[3 * 5], 1, 1, 1, 0) &&
              near3(&m.positions[3 * 6], 0, 1, 1, 0));
    CHECK("ply big-endian file normals read and normalised",
          near3(&m.normals[3 * 3], 1, 0, 0, 1e-6f) && near3(&m.normals[3 * 6], 1, 0, 0, 1e-6f));
    CHECK("ply big-endian uchar colours / 255",
          near3(&m.colors[3 * 3], 1, 0, 0, 1e-6f) && near3(&m.colors[3 * 6], 1, 0, 0.6f, 1e-6f));
    CHECK("ply big-endian leaves earlier vertices alone", near3(&m.colors[0], 1, 1, 1, 0) &&
                                                              near3(&m.normals[0], 0, 0, 1, 1e-6f));
    mesh_free(&m);
}

/* ASCII values are a stream: a line with a value too many shifts everything after it, which shows at
 * the end as values left over, or as a read failing later on another element (out of values:
 * "truncated"). Refused, naming the line at fault wherever it is; trailing blank lines are fine. */
static void test_ply_values_left_over(void)
{
    const char *head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                       "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                       "0 0 0\n1 0 0\n0 0 1\n";
    char text[512];
    snprintf(text, sizeof text, "%s3 0 1 2 7\n", head);
    const char *path = write_tmp("left_over.ply", text);
    mesh m = {0};
    vx_err e = {{0}};
    int rc = mesh_load_ply(path, &m, 0, &e);
    CHECK("ply a value too many on the last line: refused, naming the line",
          rc != 0 && strstr(e.msg, "line 13 (face 0): 5 values where its properties take 4") && m.triangle_count == 0);
    /* Mid-file: vertex 1 has a fourth value; the stream then ran out inside the face ("truncated"). */
    path = write_tmp("mid_extra.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                      "end_header\n0 0 0\n1 0 0 5\n0 0 1\n3 0 1 2\n");
    rc = mesh_load_ply(path, &m, 0, &e);
    CHECK("ply a value too many mid-file: the line is named, not \"truncated\"",
          rc != 0 && strstr(e.msg, "line 11 (vertex 1): 4 values where its properties take 3") &&
              !strstr(e.msg, "truncated") && m.triangle_count == 0);
    /* A value too few, with blank lines before it (they hold no element, but count as lines). */
    path = write_tmp("mid_short.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                      "end_header\n0 0 0\n\n1 0 0\n0 1\n3 0 1 2\n");
    rc = mesh_load_ply(path, &m, 0, &e);
    CHECK("ply a value too few: the line is named", rc != 0 && strstr(e.msg, "line 13 (vertex 2): 2 values, too few"));
    /* A list shorter than its count. */
    path = write_tmp("short_list.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                       "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
                                       "end_header\n0 0 0\n1 0 0\n0 0 1\n3 0 1\n3 0 1 2\n");
    rc = mesh_load_ply(path, &m, 0, &e);
    CHECK("ply a list shorter than its count: the line is named",
          rc != 0 && strstr(e.msg, "line 13 (face 0): 3 values where its properties take 4"));
    /* A file that ends early is still "truncated". */
    path = write_tmp("ends_early.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                       "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                       "end_header\n0 0 0\n1 0 0\n0 0 1\n  \n");
    rc = mesh_load_ply(path, &m, 0, &e);
    CHECK("ply ending before its last element: truncated", rc != 0 && strstr(e.msg, "truncated"));
    snprintf(text, sizeof text, "%s3 0 1 2\n\n  \r\n", head);
    path = write_tmp("blank_tail.ply", text);
    rc = mesh_load_ply(path, &m, 0, &e);
    CHECK("ply blank lines after the last element: loaded", rc == 0 && m.triangle_count == 1);
    mesh_free(&m);
}

static void test_ply_degenerate(void)
{
    /* Zero-area triangles (a repeated index, collinear corners) are kept for the scene loader to
     * count and drop; loading them must not crash or produce NaN normals. */
    const char *path = write_tmp("degenerate.ply", "ply\nformat ascii 1.0\nelement vertex 3\n"
                                                   "property float x\nproperty float y\nproperty float z\n"
                                                   "element face 2\nproperty list uchar int vertex_indices\n"
                                                   "end_header\n0 0 0\n1 0 0\n2 0 0\n3 0 0 1\n3 0 1 2\n");
    mesh m = {0};
    vx_err e = {{0}};
    int rc = mesh_load_ply(path, &m, 0, &e);
    CHECK("ply zero-area triangles load", rc == 0);
    CHECK("ply zero-area triangles are kept", m.triangle_count == 2);
    bool finite = true;
    for (size_t i = 0; i < 3 * m.vertex_count; i++)
        finite &= isfinite(m.normals[i]) != 0;
    CHECK("ply zero-area triangles give finite normals", finite);
    mesh_free(&m);
}

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

static void test_ply_bunny(void)
{
    const char *path = "../shared/data/meshes/bunny.ply";
    if (access(path, R_OK) != 0) {
        printf("ok ply bunny # skipped: %s not found\n", path);
        return;
    }
    /* Best of three, so a busy machine does not fail the timing check by accident. */
    double best = 1e30;
    for (int run = 0; run < 3; run++) {
        mesh m = {0};
        vx_err e = {{0}};
        double t0 = now_ms();
        int rc = mesh_load_ply(path, &m, 0, &e);
        double ms = now_ms() - t0;
        best = ms < best ? ms : best;
        if (run == 0) {
            CHECK("ply bunny loads", rc == 0);
            if (rc)
                printf("# %s\n", e.msg);
            CHECK("ply bunny 35947 vertices", m.vertex_count == 35947);
            CHECK("ply bunny 69451 triangles", m.triangle_count == 69451);
            bool unit = true;
            for (size_t i = 0; i < m.vertex_count; i++) {
                const float *n = &m.normals[3 * i];
                unit &= fabsf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1.0f) < 1e-4f;
            }
            CHECK("ply bunny smooth normals are unit length", unit);
        }
        mesh_free(&m);
    }
    printf("# bunny.ply loaded in %.1f ms (best of 3)\n", best);
#ifdef __SANITIZE_ADDRESS__
    /* Instrumented, the load takes about 50 ms here: half the limit, too near it on a loaded machine. */
    printf("ok ply bunny loads in under 100 ms # skipped: AddressSanitizer build\n");
#else
    CHECK("ply bunny loads in under 100 ms", best < 100.0);
#endif
}

static void test_ply_errors(void)
{
    expect_fail("ply NaN vertex", mesh_load_ply, "tests/data/nan_vertex.ply", "vertex 2 has a non-finite coordinate");
    expect_fail("ply truncated", mesh_load_ply, "tests/data/truncated.ply", "truncated");
    expect_fail("ply missing file", mesh_load_ply, "tests/data/no_such_file.ply", "cannot open");
    static const char *head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                              "property float z\n";
    char text[1024];
    snprintf(text, sizeof text, "%selement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", head);
    expect_fail("ply index out of range", mesh_load_ply, write_tmp("range.ply", text), "out of range");
    snprintf(text, sizeof text, "%send_header\n0 0 0\n1 0 0\n0 1 0\n", head);
    expect_fail("ply no face element", mesh_load_ply, write_tmp("noface.ply", text), "element face");
    expect_fail("ply no vertex element", mesh_load_ply,
                write_tmp("novertex.ply", "ply\nformat ascii 1.0\nelement face 0\n"
                                          "property list uchar int vertex_indices\nend_header\n"),
                "element vertex");
    expect_fail("ply no z property", mesh_load_ply,
                write_tmp("noz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                     "property float y\nelement face 0\n"
                                     "property list uchar int vertex_indices\nend_header\n0 0\n"),
                "lacks property z");
    expect_fail("ply unknown format", mesh_load_ply,
                write_tmp("format.ply", "ply\nformat binary_middle_endian 1.0\nelement vertex 0\n"
                                        "end_header\n"),
                "unknown PLY format");
    expect_fail("ply not a ply", mesh_load_ply, write_tmp("notply.ply", "solid cube\n"), "not a PLY file");
    expect_fail("ply no end_header", mesh_load_ply,
                write_tmp("noend.ply", "ply\nformat ascii 1.0\nelement vertex 0\n"), "end_header");
    expect_fail("ply unknown property type", mesh_load_ply,
                write_tmp("type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\n"
                                      "end_header\n"),
                "unknown property type");
    snprintf(text, sizeof text, "%selement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                "0 0 0\n1 0 0\n0 1 0\n3 0 one 2\n", head);
    expect_fail("ply ascii garbage", mesh_load_ply, write_tmp("garbage.ply", text), "expected a number");
}

static void test_gltf_quad(const char *path, bool glb)
{
    char label[256];
    const char *kind = glb ? "glb" : "gltf";
    mesh m = {0};
    vx_err e = {{0}};
    int rc = mesh_load_gltf(path, &m, 5, &e);
    snprintf(label, sizeof label, "%s loads", kind);
    CHECK(label, rc == 0);
    if (rc) {
        printf("# %s\n", e.msg);
        return;
    }
    /* The glb adds a second, unindexed one-triangle primitive; its POINTS primitive is skipped. */
    snprintf(label, sizeof label, "%s counts", kind);
    CHECK(label, m.vertex_count == (glb ? 7u : 4u) && m.triangle_count == (glb ? 3u : 2u));
    if (m.vertex_count < 4)
        return;
    /* world = translate(1, 2, 3) * scale(2, 1, 1) * local */
    snprintf(label, sizeof label, "%s node transforms applied to positions", kind);
    CHECK(label, near3(&m.positions[0], 1, 2, 3, 1e-6f) && near3(&m.positions[3], 3, 1, 3, 1e-6f) &&
                     near3(&m.positions[6], 3, 1, 4, 1e-6f) && near3(&m.positions[9], 1, 2, 4, 1e-6f));
    static const uint32_t want[6] = {0, 1, 2, 0, 2, 3};
    snprintf(label, sizeof label, "%s indices", kind);
    CHECK(label, memcmp(m.indices, want, sizeof want) == 0);
    snprintf(label, sizeof label, "%s material index", kind);
    CHECK(label, m.materials[0] == 5 && m.materials[1] == 5);
    /* (-1, -1, 0) under the inverse transpose of scale(2, 1, 1) is (-1, -2, 0) after normalising. */
    float s = 1.0f / sqrtf(5.0f);
    snprintf(label, sizeof label, "%s normals by the inverse transpose", kind);
    CHECK(label, near3(&m.normals[0], -s, -2 * s, 0, 1e-6f) && near3(&m.normals[9], -s, -2 * s, 0, 1e-6f));
    snprintf(label, sizeof label, "%s texture coordinates", kind);
    CHECK(label, m.uvs[2] == 1 && m.uvs[3] == 0 && m.uvs[6] == 0 && m.uvs[7] == 1);
    snprintf(label, sizeof label, "%s baseColorFactor becomes the vertex colour", kind);
    CHECK(label, near3(&m.colors[0], 0.8f, 0.4f, 0.2f, 1e-6f) && near3(&m.colors[9], 0.8f, 0.4f, 0.2f, 1e-6f));
    if (glb && m.vertex_count == 7) {
        CHECK("glb unindexed primitive positions",
              near3(&m.positions[12], 1, 2, 3, 1e-6f) && near3(&m.positions[15], 3, 2, 3, 1e-6f) &&
                  near3(&m.positions[18], 1, 3, 3, 1e-6f));
        CHECK("glb unindexed primitive triangle", m.indices[6] == 4 && m.indices[7] == 5 && m.indices[8] == 6);
        CHECK("glb primitive without normals gets its triangle's normal (flat; the other primitive keeps its NORMAL)",
              near3(&m.normals[12], 0, 0, 1, 1e-6f) && near3(&m.normals[15], 0, 0, 1, 1e-6f) &&
                  near3(&m.normals[18], 0, 0, 1, 1e-6f));
        CHECK("glb primitive without material is white", near3(&m.colors[12], 1, 1, 1, 0));
    }
    mesh_free(&m);
}

static void test_gltf_mirrored(void)
{
    mesh m = {0};
    vx_err e = {{0}};
    int rc = mesh_load_gltf("tests/data/mirrored.gltf", &m, 0, &e);
    CHECK("gltf mirrored loads", rc == 0);
    if (rc) {
        printf("# %s\n", e.msg);
        return;
    }
    /* scale(1, 1, -1) turns the counter-clockwise triangle clockwise: the loader swaps two corners. */
    CHECK("gltf mirrored winding flipped", m.triangle_count == 1 && m.indices[0] == 0 && m.indices[1] == 2 &&
                                               m.indices[2] == 1);
    CHECK("gltf mirrored normal", near3(&m.normals[0], 0, 0, -1, 1e-6f));
    mesh_free(&m);
}

/* The loader with its own materials (images decoded), as the scene loader calls it. */
static int any_material(void *ctx, int index, const gltf_material_desc *d, uint32_t *out, vx_err *e)
{
    (void)ctx, (void)index, (void)d, (void)e;
    *out = 0;
    return 0;
}

static int load_gltf_with_materials(const char *path, mesh *m, uint32_t material, vx_err *e)
{
    return mesh_load_gltf_materials(path, m, material, 0, any_material, NULL, e);
}

static void test_gltf_errors(void)
{
    /* fuzz_gltf's find: an embedded PNG whose bufferView reaches past its buffer's bytes (tinygltf
     * handed the decoder that range unchecked, which read past the allocation): refused, named. */
    expect_fail("glb image past its buffer", load_gltf_with_materials, "tests/data/image_past_buffer.glb",
                "which holds");
    expect_fail("gltf points only", mesh_load_gltf, "tests/data/points.gltf",
                "no triangle primitives (glTF mode 4)");
    expect_fail("gltf NaN position (scene-less file)", mesh_load_gltf, "tests/data/nan_position.gltf",
                "vertex 1 has a non-finite position");
    expect_fail("gltf accessor out of bounds", mesh_load_gltf, "tests/data/out_of_bounds.gltf", "out of bounds");
    expect_fail("gltf unknown extension", mesh_load_gltf, "tests/data/quad_ascii.ply", "expected .gltf or .glb");
    expect_fail("gltf missing file", mesh_load_gltf, "tests/data/no_such_file.gltf", "cannot open glTF file");
    expect_fail("gltf malformed JSON", mesh_load_gltf, write_tmp("bad.gltf", "{\"asset\": {\"version\": "),
                "tinygltf");
    /* The scene file's rule for the glTF's JSON (json_util.h): each key once (tinygltf would keep
     * one of the values without a word), nothing after the document. */
    expect_fail("gltf key twice", mesh_load_gltf,
                write_tmp("dup.gltf", "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"meshes\":[{\"primitives\":"
                                      "[{\"attributes\":{\"POSITION\":0,\"POSITION\":1}}]}]}"),
                "meshes[0].primitives[0].attributes.POSITION appears twice");
    expect_fail("gltf text after the document", mesh_load_gltf,
                write_tmp("trail.gltf", "{\"asset\":{\"version\":\"2.0\"}}\n{}"),
                "line 2: text after the JSON document");
    /* The same in a .glb's JSON chunk (header, chunk length and type "JSON", the JSON padded to 4). */
    static const char dup_json[] = "{\"asset\":{\"version\":\"2.0\"},\"asset\":{\"version\":\"2.0\"}}  ";
    unsigned char glb[12 + 8 + sizeof dup_json - 1] = {'g', 'l', 'T', 'F', 2, 0, 0, 0, sizeof glb, 0, 0, 0,
                                                       sizeof dup_json - 1, 0, 0, 0, 'J', 'S', 'O', 'N'};
    memcpy(glb + 20, dup_json, sizeof dup_json - 1);
    expect_fail("glb key twice in its JSON chunk", mesh_load_gltf, write_tmp_bytes("dup.glb", glb, sizeof glb),
                "JSON chunk: asset appears twice");
    expect_fail("gltf Draco-compressed", mesh_load_gltf,
                write_tmp("draco.gltf", "{\"asset\":{\"version\":\"2.0\"},"
                                        "\"extensionsUsed\":[\"KHR_draco_mesh_compression\"],"
                                        "\"extensionsRequired\":[\"KHR_draco_mesh_compression\"]}"),
                "KHR_draco_mesh_compression");
    expect_fail("glb not binary glTF", mesh_load_gltf, write_tmp("bad.glb", "not a glb file at all"), "tinygltf");
    expect_fail("gltf 1.0 refused by its version", mesh_load_gltf,
                write_tmp("v1.gltf", "{\"asset\":{\"version\":\"1.0\"},\"meshes\":{}}"), "glTF 1.0 is not supported");
    /* A GLB header of version 1 (magic, version, length: zeros included, so written with fwrite). */
    static const unsigned char glb1[20] = {'g', 'l', 'T', 'F', 1, 0, 0, 0, 20, 0, 0, 0};
    expect_fail("glb 1.0 refused by its version", mesh_load_gltf, write_tmp_bytes("v1.glb", glb1, sizeof glb1),
                "glTF 1.0 is not supported");
}

/* OBJ: the fixture quad (one polygon with vt and vn) and a file without normals, against the values
 * written into them; then the refusals. */
static void test_obj(void)
{
    mesh m = {0};
    vx_err e;
    CHECK("obj quad loads", mesh_load_obj("tests/data/quad.obj", &m, 4, &e) == 0);
    CHECK("obj quad: one polygon fan-triangulated into 2 triangles of material 4, 4 shared corners",
          m.triangle_count == 2 && m.vertex_count == 4 && m.materials[0] == 4 && m.materials[1] == 4);
    int ok = 1;
    for (size_t v = 0; v < m.vertex_count; v++) {
        ok &= near3(&m.normals[3 * v], 0, 0, 1, 1e-6f);
        ok &= m.uvs[2 * v] == m.positions[3 * v] && m.uvs[2 * v + 1] == m.positions[3 * v + 1]; /* vt = xy here */
    }
    CHECK("obj quad: normals from vn, uvs from vt", ok);
    mesh_free(&m);
    memset(&m, 0, sizeof m);
    const char *tent = "v 0 0 0\nv 1 0 0\nv 1 1 1\nv 0 1 1\nv 0.5 0 -1\nf 1 2 3\nf -5 -3 -2\nf 1 5 2\n";
    CHECK("obj without normals loads (relative indices)", mesh_load_obj(write_tmp("tent.obj", tent), &m, 0, &e) == 0);
    float len = 0;
    for (int k = 0; k < 3; k++)
        len += m.normals[k] * m.normals[k];
    CHECK("obj without normals: 3 triangles on 5 shared vertices, smooth unit normals",
          m.triangle_count == 3 && m.vertex_count == 5 && fabsf(len - 1.0f) < 1e-5f);
    mesh_free(&m);
    expect_fail("obj index out of range", mesh_load_obj, write_tmp("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
                "out of range");
    expect_fail("obj normal index out of range", mesh_load_obj,
                write_tmp("nrange.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//2 3//1\n"), "normal 2");
    expect_fail("obj no faces", mesh_load_obj, write_tmp("nofaces.obj", "v 0 0 0\nv 1 0 0\n"), "no faces");
    expect_fail("obj non-finite vertex", mesh_load_obj,
                write_tmp("inf.obj", "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n"), "non-finite");
    /* tinyobjloader reads these as 0: the mesh would be another, plausible one (the audit's finds). */
    expect_fail("obj NaN coordinate", mesh_load_obj, write_tmp("nan.obj", "v nan 0 -1\nv -1 0 1\nv 1 0 1\nf 1 2 3\n"),
                "line 1 (\"v nan 0 -1\"): a malformed or non-finite number \"nan\"");
    expect_fail("obj non-numeric coordinate", mesh_load_obj,
                write_tmp("abc.obj", "v 0 0 -1\nv abc 0 1\nv 1 0 1\nf 1 2 3\n"), "line 2 (\"v abc 0 1\")");
    expect_fail("obj coordinates missing", mesh_load_obj, write_tmp("short.obj", "v 0 0 -1\nv 1\nv 1 0 1\nf 1 2 3\n"),
                "line 2 (\"v 1\"): expected 3 to 7 numbers, found 1");
    expect_fail("obj NaN texture coordinate", mesh_load_obj,
                write_tmp("vtnan.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt nan 0\nf 1/1 2/1 3/1\n"), "line 4");
    expect_fail("obj NaN normal", mesh_load_obj,
                write_tmp("vnnan.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn nan 1 0\nf 1//1 2//1 3//1\n"), "line 4");
    expect_fail("obj texture coordinate beyond a float", mesh_load_obj,
                write_tmp("vtbig.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 1e300 0\nf 1/1 2/1 3/1\n"),
                "texture coordinate 1 is not finite");
    expect_fail("ply NaN texture coordinate", mesh_load_ply,
                write_tmp("uvnan.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                       "property float z\nproperty float u\nproperty float v\nelement face 1\n"
                                       "property list uchar int vertex_indices\nend_header\n0 0 0 nan 0\n1 0 0 1 0\n"
                                       "0 1 0 0 1\n3 0 1 2\n"),
                "vertex 0 has a non-finite texture coordinate");
    expect_fail("gltf NaN TEXCOORD_0", mesh_load_gltf, "tests/data/nan_uv.gltf", "TEXCOORD_0 of vertex 1 is not finite");
    expect_fail("obj missing file", mesh_load_obj, "tests/data/no_such_file.obj", "cannot open");
    expect_fail("obj directory", mesh_load_obj, "tests/data", "not a regular file");
}

/* mesh_crease_normals against normals worked out by hand: a cube on 8 shared corners gets 24 corner
 * vertices, each with its face's normal, and the same positions; a regular octahedron's 109-degree
 * edges split it the same way (8 faces x 3 corners); an icosahedron's 42-degree edges keep its 12
 * vertices, each with its radial direction (the area-weighted mean of 5 congruent faces); a
 * zero-area triangle on a flat patch takes the patch's normal. Before the crease rule, the cube's
 * corners pointed along the diagonals. */
static void test_crease_normals(void)
{
    mesh m = {0};
    static const int faces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
    for (int k = 0; k < 8; k++)
        mesh_add_vertex(&m, v3(k & 1 ? 1.0f : -1.0f, k & 2 ? 1.0f : -1.0f, k & 4 ? 1.0f : -1.0f), v3(0, 0, 0), 0, 0);
    for (int f = 0; f < 6; f++) {
        mesh_add_triangle(&m, faces[f][0], faces[f][1], faces[f][2], 0);
        mesh_add_triangle(&m, faces[f][0], faces[f][2], faces[f][3], 0);
    }
    mesh_crease_normals(&m, 0, 0, MESH_CREASE_DEG);
    int ok = m.vertex_count == 24;
    for (size_t t = 0; t < m.triangle_count; t++) {
        const uint32_t *tri = &m.indices[3 * t];
        vec3 a = mesh_position(&m, tri[0]), b = mesh_position(&m, tri[1]), c = mesh_position(&m, tri[2]);
        vec3 n = v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
        for (int k = 0; k < 3; k++)
            ok &= near3(&m.normals[3 * tri[k]], n.x, n.y, n.z, 1e-6f);
    }
    CHECK("crease normals: a cube on 8 shared corners gets 24 vertices with its faces' normals", ok);
    mesh_free(&m);

    memset(&m, 0, sizeof m);
    const vec3 oct[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int k = 0; k < 6; k++)
        mesh_add_vertex(&m, oct[k], v3(0, 0, 0), 0, 0);
    for (int sx = 0; sx < 2; sx++)
        for (int sy = 0; sy < 2; sy++)
            for (int sz = 0; sz < 2; sz++) {
                uint32_t a = (uint32_t)sx, b = (uint32_t)(2 + sy), c = (uint32_t)(4 + sz);
                if ((sx + sy + sz) % 2) /* outward winding */
                    mesh_add_triangle(&m, a, c, b, 0);
                else
                    mesh_add_triangle(&m, a, b, c, 0);
            }
    mesh_crease_normals(&m, 0, 0, MESH_CREASE_DEG);
    CHECK("crease normals: an octahedron (109-degree edges) splits into 24 flat corners", m.vertex_count == 24);
    mesh_free(&m);

    memset(&m, 0, sizeof m);
    const float g = 1.6180340f;
    const vec3 ico[12] = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                          {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
    static const int tris[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                    {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                                    {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (int k = 0; k < 12; k++)
        mesh_add_vertex(&m, ico[k], v3(0, 0, 0), 0, 0);
    for (int t = 0; t < 20; t++)
        mesh_add_triangle(&m, (uint32_t)tris[t][0], (uint32_t)tris[t][1], (uint32_t)tris[t][2], 0);
    mesh_crease_normals(&m, 0, 0, MESH_CREASE_DEG);
    ok = m.vertex_count == 12;
    for (size_t v = 0; v < 12 && ok; v++) {
        vec3 r = v3_normalize(mesh_position(&m, (uint32_t)v));
        ok &= near3(&m.normals[3 * v], r.x, r.y, r.z, 1e-5f);
    }
    CHECK("crease normals: an icosahedron (42-degree edges) keeps 12 smooth radial normals", ok);
    mesh_free(&m);

    memset(&m, 0, sizeof m);
    mesh_add_vertex(&m, v3(0, 0, 0), v3(0, 0, 0), 0, 0);
    mesh_add_vertex(&m, v3(1, 0, 0), v3(0, 0, 0), 0, 0);
    mesh_add_vertex(&m, v3(0, 1, 0), v3(0, 0, 0), 0, 0);
    mesh_add_vertex(&m, v3(2, 0, 0), v3(0, 0, 0), 0, 0);
    mesh_add_triangle(&m, 0, 1, 2, 0);
    mesh_add_triangle(&m, 0, 1, 3, 0); /* collinear: zero area */
    mesh_crease_normals(&m, 0, 0, MESH_CREASE_DEG);
    ok = m.vertex_count == 4;
    for (size_t v = 0; v < m.vertex_count; v++)
        ok &= near3(&m.normals[3 * v], 0, 0, 1, 1e-6f);
    CHECK("crease normals: a zero-area triangle takes its neighbour's normal, no split", ok);
    mesh_free(&m);
}

/* mesh_flat_normals on a bent quad worked out by hand: corners (0,0,0), (1,0,0), (1,1,0), (0,1,1)
 * shared by triangles (0,1,2), normal +z, and (0,2,3), normal (1,-1,1)/sqrt 3; each triangle gets
 * three vertices of its own with its normal and its corners' positions, uvs and colours; a vertex no
 * triangle uses goes; an earlier object's triangle and vertices stay as they were. Before, a glTF
 * primitive without NORMAL got smooth normals: its shared corners (0,0,0) and (1,1,0) pointed
 * along (1,-1,2)/sqrt 6. */
static const float bent_pos[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 1}};
static const uint16_t bent_idx[6] = {0, 1, 2, 0, 2, 3};

static bool bent_normals_flat(const mesh *m, size_t t0)
{
    const float r = 1.0f / sqrtf(3.0f);
    bool ok = m->triangle_count == t0 + 2;
    for (int k = 0; ok && k < 3; k++)
        ok = near3(&m->normals[3 * m->indices[3 * t0 + (size_t)k]], 0, 0, 1, 1e-6f) &&
             near3(&m->normals[3 * m->indices[3 * t0 + 3 + (size_t)k]], r, -r, r, 1e-6f);
    return ok;
}

static void test_flat_normals(void)
{
    mesh m = {0};
    mesh_add_flat_triangle(&m, v3(5, 5, 5), v3(6, 5, 5), v3(5, 5, 4), 3); /* normal (0, 1, 0) */
    for (int k = 0; k < 4; k++) {
        uint32_t v = mesh_add_vertex(&m, v3(bent_pos[k][0], bent_pos[k][1], bent_pos[k][2]), v3(0, 0, 0),
                                     0.25f * (float)k, 1.0f - 0.25f * (float)k);
        mesh_set_vertex_color(&m, v, v3(0.1f * (float)k, 0.2f, 0.3f + 0.1f * (float)k));
    }
    mesh_add_vertex(&m, v3(9, 9, 9), v3(0, 0, 1), 0, 0); /* used by no triangle */
    mesh_add_triangle(&m, 3 + bent_idx[0], 3 + bent_idx[1], 3 + bent_idx[2], 7);
    mesh_add_triangle(&m, 3 + bent_idx[3], 3 + bent_idx[4], 3 + bent_idx[5], 8);
    mesh_flat_normals(&m, 3, 1);
    CHECK("flat normals: 3 vertices per triangle (the unused one gone)", m.vertex_count == 3 + 6 && m.triangle_count == 3);
    bool own = true, kept = true;
    for (size_t i = 0; i < 6; i++) {
        uint32_t v = m.indices[3 + i], k = bent_idx[i];
        own &= v == 3 + i;
        kept &= near3(&m.positions[3 * v], bent_pos[k][0], bent_pos[k][1], bent_pos[k][2], 0) &&
                m.uvs[2 * v] == 0.25f * (float)k && m.uvs[2 * v + 1] == 1.0f - 0.25f * (float)k &&
                near3(&m.colors[3 * v], 0.1f * (float)k, 0.2f, 0.3f + 0.1f * (float)k, 0);
    }
    CHECK("flat normals: each corner its own vertex, in triangle order", own);
    CHECK("flat normals: each corner keeps its position, uv and colour", kept);
    CHECK("flat normals: each triangle's corners carry its face normal (1e-6)", bent_normals_flat(&m, 1));
    CHECK("flat normals: materials kept, normals_smoothed not set", m.materials[1] == 7 && m.materials[2] == 8 &&
                                                                       !m.normals_smoothed);
    CHECK("flat normals: the earlier object's triangle untouched",
          m.indices[0] == 0 && m.indices[1] == 1 && m.indices[2] == 2 && near3(&m.positions[3], 6, 5, 5, 0) &&
              near3(&m.normals[0], 0, 1, 0, 1e-6f) && near3(&m.normals[6], 0, 1, 0, 1e-6f));
    mesh_free(&m);
}

/* The same bent quad as a glTF primitive on 4 shared vertices without NORMAL (external buffer): flat
 * normals (glTF 2.0: "client implementations MUST calculate flat normals"), 6 vertices; for an
 * object to be subdivided, the 4 shared vertices with smooth normals (the area-weighted means). */
static void test_gltf_without_normals(void)
{
    unsigned char bin[60];
    memcpy(bin, bent_pos, 48);
    memcpy(bin + 48, bent_idx, 12);
    write_tmp_bytes("bent.bin", bin, sizeof bin);
    const char *path = write_tmp(
        "bent.gltf",
        "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}], \"nodes\": [{\"mesh\": 0}],"
        " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1}]}],"
        " \"buffers\": [{\"byteLength\": 60, \"uri\": \"bent.bin\"}],"
        " \"bufferViews\": [{\"buffer\": 0, \"byteLength\": 48}, {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 12}],"
        " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\","
        " \"min\": [0, 0, 0], \"max\": [1, 1, 1]},"
        " {\"bufferView\": 1, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"}]}");
    mesh m = {0};
    vx_err e = {{0}};
    int rc = mesh_load_gltf(path, &m, 0, &e);
    if (rc)
        printf("# %s\n", e.msg);
    CHECK("gltf without NORMAL: flat normals, 3 vertices per triangle",
          rc == 0 && m.vertex_count == 6 && bent_normals_flat(&m, 0));
    mesh_free(&m);
    memset(&m, 0, sizeof m);
    rc = mesh_load_gltf_files(path, &m, 0, 0, 1, NULL, NULL, NULL, NULL, &e);
    if (rc)
        printf("# %s\n", e.msg);
    const float h = 1.0f / sqrtf(6.0f), r = 1.0f / sqrtf(3.0f);
    CHECK("gltf without NORMAL, to be subdivided: shared vertices, smooth normals",
          rc == 0 && m.vertex_count == 4 && near3(&m.normals[0], h, -h, 2 * h, 1e-6f) &&
              near3(&m.normals[3], 0, 0, 1, 1e-6f) && near3(&m.normals[6], h, -h, 2 * h, 1e-6f) &&
              near3(&m.normals[9], r, -r, r, 1e-6f));
    mesh_free(&m);
}

int main(void)
{
    make_tmp_dir();
    test_ply_ascii();
    test_ply_big_endian();
    test_ply_degenerate();
    test_ply_values_left_over();
    test_ply_bunny();
    test_ply_errors();
    test_gltf_quad("tests/data/quad.gltf", false);
    test_gltf_quad("tests/data/quad.glb", true);
    test_gltf_mirrored();
    test_gltf_errors();
    test_obj();
    test_crease_normals();
    test_flat_normals();
    test_gltf_without_normals();
    remove_tmp_files();
    return unit_exit();
}
