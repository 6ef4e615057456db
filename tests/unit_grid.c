/* Voxel grid, triangle/box overlap and DDA traversal. Expectations are computed independently of
 * the code under test: cube counts from the documented mapping, sphere voxelisation by clipping
 * every triangle against every cell (Sutherland-Hodgman, not SAT) and by an analytic shell
 * sandwich, traversal by slab-testing every non-empty cell. Also reports build time and memory of
 * the Stanford bunny at 128/256/512 and the DDA's speed.
 *
 * Touching convention under test: cells are closed boxes, so a triangle lying exactly on the plane
 * between two cell layers marks both layers, and one whose edge lies on a cell edge marks all four
 * cells around that edge. */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cone_skip.h"
#include "grid.h"
#include "grid_traverse_core.h"
#include "mesh.h"
#include "rng.h"
#include "tribox.h"
#include "unit.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---------- independent triangle/box overlap: clip the triangle by the box's six half-spaces ---------- */

static int clip_overlap(const double tri[3][3], const double lo[3], const double hi[3])
{
    double poly[16][3], out[16][3];
    int count = 3;
    memcpy(poly, tri, sizeof(double[3][3]));
    for (int a = 0; a < 3 && count; a++)
        for (int side = 0; side < 2 && count; side++) {
            int m = 0;
            for (int i = 0; i < count; i++) {
                const double *p = poly[i], *q = poly[(i + 1) % count];
                double fp = side ? hi[a] - p[a] : p[a] - lo[a];
                double fq = side ? hi[a] - q[a] : q[a] - lo[a];
                if (fp >= 0)
                    memcpy(out[m++], p, sizeof(double[3]));
                if ((fp >= 0) != (fq >= 0)) {
                    double s = fp / (fp - fq);
                    for (int k = 0; k < 3; k++)
                        out[m][k] = p[k] + (q[k] - p[k]) * s;
                    out[m][a] = side ? hi[a] : lo[a];
                    m++;
                }
            }
            count = m;
            memcpy(poly, out, sizeof(double[3]) * (size_t)m);
        }
    return count > 0;
}

/* ---------- meshes ---------- */

static void add_icosphere(mesh *m, vec3 c, float r, int depth)
{
    const float t = 1.6180339887f;
    vec3 v[12] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                  {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    static const int f[20][3] = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                                 {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
    /* Recursive subdivision into a stack of triangles; vertices are not shared (the grid does
     * not care). */
    size_t cap = 20;
    for (int i = 0; i < depth; i++)
        cap *= 4;
    vec3(*tris)[3] = malloc(cap * sizeof *tris);
    size_t nt = 0;
    for (int i = 0; i < 20; i++) {
        tris[nt][0] = v3_normalize(v[f[i][0]]);
        tris[nt][1] = v3_normalize(v[f[i][1]]);
        tris[nt][2] = v3_normalize(v[f[i][2]]);
        nt++;
    }
    for (int d = 0; d < depth; d++) {
        size_t old = nt;
        for (size_t i = 0; i < old; i++) {
            vec3 a = tris[i][0], b = tris[i][1], cc = tris[i][2];
            vec3 ab = v3_normalize(v3_add(a, b)), bc = v3_normalize(v3_add(b, cc)), ca = v3_normalize(v3_add(cc, a));
            vec3 q[4][3] = {{a, ab, ca}, {ab, b, bc}, {ca, bc, cc}, {ab, bc, ca}};
            memcpy(tris[i], q[0], sizeof q[0]);
            for (int k = 1; k < 4; k++)
                memcpy(tris[nt++], q[k], sizeof q[k]);
        }
    }
    for (size_t i = 0; i < nt; i++)
        mesh_add_flat_triangle(m, v3_madd(c, tris[i][0], r), v3_madd(c, tris[i][1], r), v3_madd(c, tris[i][2], r), 0);
    free(tris);
}

/* Quick local reader for the binary little-endian bunny (float x y z, uchar-count int faces), so
 * this test does not depend on the project's loader. Returns 0 on success. */
static int load_bunny(const char *path, mesh *m)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return -1;
    char line[256];
    long nv = -1, nf = -1;
    int props = 0, ok = 0;
    while (fgets(line, sizeof line, f)) {
        if (sscanf(line, "element vertex %ld", &nv) == 1)
            continue;
        if (sscanf(line, "element face %ld", &nf) == 1)
            continue;
        if (nf < 0 && strncmp(line, "property float", 14) == 0)
            props++;
        if (strncmp(line, "end_header", 10) == 0) {
            ok = 1;
            break;
        }
    }
    if (!ok || nv <= 0 || nf <= 0 || props != 3) {
        fclose(f);
        return -1;
    }
    for (long i = 0; i < nv; i++) {
        float p[3];
        if (fread(p, sizeof p, 1, f) != 1) {
            fclose(f);
            return -1;
        }
        mesh_add_vertex(m, v3(p[0], p[1], p[2]), v3(0, 0, 1), 0, 0);
    }
    for (long i = 0; i < nf; i++) {
        unsigned char k;
        int32_t idx[16];
        if (fread(&k, 1, 1, f) != 1 || k < 3 || k > 16 || fread(idx, 4, k, f) != k) {
            fclose(f);
            return -1;
        }
        for (int j = 1; j + 1 < k; j++)
            mesh_add_triangle(m, (uint32_t)idx[0], (uint32_t)idx[j], (uint32_t)idx[j + 1], 0);
    }
    fclose(f);
    return 0;
}

/* ---------- helpers over a built grid ---------- */

static size_t scan_count(const voxel_grid *g, int level)
{
    int n = g->level[level].n;
    size_t c = 0;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++)
            for (int z = 0; z < n; z++)
                c += grid_index(g, level, x, y, z) >= 0;
    return c;
}

/* Voxels whose closed box touches the surface of the axis-aligned box [blo, bhi] (lattice units):
 * the cell meets the solid box, and on some axis it reaches one of the two face planes. */
static size_t box_surface_count(const double blo[3], const double bhi[3], int n)
{
    size_t c = 0;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++)
            for (int z = 0; z < n; z++) {
                int p[3] = {x, y, z}, meets = 1, face = 0;
                for (int a = 0; a < 3; a++) {
                    if (p[a] + 1 < blo[a] || p[a] > bhi[a])
                        meets = 0;
                    if ((p[a] <= blo[a] && p[a] + 1 >= blo[a]) || (p[a] <= bhi[a] && p[a] + 1 >= bhi[a]))
                        face = 1;
                }
                c += meets && face;
            }
    return c;
}

static int mip_consistent(const voxel_grid *g)
{
    for (int l = 1; l < g->levels; l++) {
        int n = g->level[l].n, nf = g->level[l - 1].n;
        size_t c = 0;
        for (int x = 0; x < n; x++)
            for (int y = 0; y < n; y++)
                for (int z = 0; z < n; z++) {
                    int any = 0;
                    for (int k = 0; k < 8; k++) {
                        int cx = 2 * x + (k & 1), cy = 2 * y + ((k >> 1) & 1), cz = 2 * z + (k >> 2);
                        if (cx < nf && cy < nf && cz < nf && grid_index(g, l - 1, cx, cy, cz) >= 0)
                            any = 1;
                    }
                    /* grid_level_occupied reads the level's plain bits where it keeps them. */
                    if (any != (grid_index(g, l, x, y, z) >= 0) || any != grid_level_occupied(&g->level[l], x, y, z))
                        return 0;
                    c += any;
                }
        if (c != grid_count(g, l))
            return 0;
    }
    return g->level[g->levels - 1].n == 1;
}

/* Every dense index maps to coordinates that map back to it, in increasing (x, y, z) order. */
static int index_roundtrip(const voxel_grid *g)
{
    for (int l = 0; l < g->levels; l++) {
        long long prev = -1;
        for (size_t i = 0; i < grid_count(g, l); i++) {
            int x, y, z;
            grid_coords(g, l, i, &x, &y, &z);
            if (grid_index(g, l, x, y, z) != (int64_t)i)
                return 0;
            long long key = ((long long)x * 1024 + y) * 1024 + z;
            if (key <= prev)
                return 0;
            prev = key;
        }
    }
    return 1;
}

static int same_grid(const voxel_grid *a, const voxel_grid *b)
{
    if (a->levels != b->levels)
        return 0;
    for (int l = 0; l < a->levels; l++)
        if (a->level[l].count != b->level[l].count ||
            memcmp(a->level[l].coords, b->level[l].coords, a->level[l].count * sizeof(uint32_t)) != 0)
            return 0;
    return 1;
}

/* ---------- tests ---------- */

static void test_tribox(void)
{
    /* Touching cases on the unit box [0,1]^3. */
    vec3 lo = v3(0, 0, 0), hi = v3(1, 1, 1);
    CHECK("tribox: triangle on a face touches", tribox_overlap(lo, hi, v3(0.2f, 0.2f, 1), v3(0.8f, 0.2f, 1), v3(0.5f, 0.9f, 1)));
    CHECK("tribox: triangle just above a face misses",
          !tribox_overlap(lo, hi, v3(0.2f, 0.2f, 1.001f), v3(0.8f, 0.2f, 1.001f), v3(0.5f, 0.9f, 1.001f)));
    CHECK("tribox: vertex on a corner touches", tribox_overlap(lo, hi, v3(1, 1, 1), v3(2, 1, 3), v3(1, 3, 2)));
    CHECK("tribox: edge along a box edge touches", tribox_overlap(lo, hi, v3(-1, 1, 1), v3(2, 1, 1), v3(0, 3, 3)));
    CHECK("tribox: edge crossing near a corner without touching misses",
          !tribox_overlap(lo, hi, v3(1.6f, 0.5f, 0.5f), v3(0.5f, 1.6f, 0.5f), v3(1.6f, 1.6f, 0.5f)));
    CHECK("tribox: big triangle through the box", tribox_overlap(lo, hi, v3(-5, -5, 0.5f), v3(5, -5, 0.5f), v3(0, 5, 0.5f)));
    CHECK("tribox: zero-area triangle (segment) through the box",
          tribox_overlap(lo, hi, v3(-1, 0.5f, 0.5f), v3(2, 0.5f, 0.5f), v3(0.5f, 0.5f, 0.5f)));
    CHECK("tribox: zero-area triangle (point) outside", !tribox_overlap(lo, hi, v3(2, 2, 2), v3(2, 2, 2), v3(2, 2, 2)));

    /* Random triangles against unit cells: the SAT (both forms) against polygon clipping. */
    rng r = rng_seed(7, 1);
    int mismatch_am = 0, mismatch_cells = 0, hits = 0, cases = 0;
    for (int i = 0; i < 20000; i++) {
        double tri[3][3];
        double size = i % 3 == 0 ? 0.3 : (i % 3 == 1 ? 1.5 : 6.0);
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++)
                tri[k][a] = 2.0 + (rng_double(&r) - 0.5) * size + (k ? tri[0][a] - 2.0 : 0.0);
        tribox_cells s;
        if (!tribox_cells_setup(&s, tri[0], tri[1], tri[2]))
            continue;
        for (int x = 0; x < 4; x++)
            for (int y = 0; y < 4; y++)
                for (int z = 0; z < 4; z++) {
                    double blo[3] = {x, y, z}, bhi[3] = {x + 1, y + 1, z + 1};
                    int want = clip_overlap(tri, blo, bhi);
                    int am = tribox_overlap_d(blo, bhi, tri[0], tri[1], tri[2]);
                    int inbox = x >= s.lo[0] && x <= s.hi[0] && y >= s.lo[1] && y <= s.hi[1] && z >= s.lo[2] &&
                                z <= s.hi[2];
                    int cells = inbox && tribox_cells_test(&s, x, y, z);
                    mismatch_am += am != want;
                    mismatch_cells += cells != want;
                    hits += want;
                    cases++;
                }
    }
    printf("# tribox: %d cases, %d overlaps, %d/%d disagreements (AM/cells) with clipping\n", cases, hits,
           mismatch_am, mismatch_cells);
    CHECK("tribox: Akenine-Moller SAT agrees with polygon clipping on random triangles", mismatch_am == 0);
    CHECK("tribox: per-cell SAT agrees with polygon clipping on random triangles", mismatch_cells == 0);

    /* Exact touching in the per-cell form: a triangle in the plane z = 3 with an edge on x = 2. */
    double a[3] = {2, 1.25, 3}, b[3] = {3.5, 1.5, 3}, c[3] = {2, 2.75, 3};
    tribox_cells s;
    CHECK("tribox cells: setup", tribox_cells_setup(&s, a, b, c));
    CHECK("tribox cells: layer below the plane", tribox_cells_test(&s, 2, 1, 2));
    CHECK("tribox cells: layer above the plane", tribox_cells_test(&s, 2, 1, 3));
    CHECK("tribox cells: cell left of the edge on x = 2 (touching)", tribox_cells_test(&s, 1, 1, 2) && tribox_cells_test(&s, 1, 2, 3));
    CHECK("tribox cells: two layers away", !tribox_cells_test(&s, 2, 1, 1) && !tribox_cells_test(&s, 2, 1, 4));
    CHECK("tribox cells: bounding box includes touching cells", s.lo[0] == 1 && s.lo[2] == 2 && s.hi[2] == 3);
    double z0[3] = {1, 1, 1};
    CHECK("tribox cells: zero-area triangle is reported", !tribox_cells_setup(&s, z0, z0, c));
}

static void test_errors(void)
{
    mesh m = {0};
    voxel_grid g;
    vx_err e = {{0}};
    CHECK("grid error: empty mesh", grid_build(&g, &m, 32, &e) < 0 && strstr(e.msg, "no triangles"));
    mesh_add_box(&m, v3(0, 0, 0), v3(1, 1, 1), 0);
    CHECK("grid error: n = 0", grid_build(&g, &m, 0, &e) < 0 && strstr(e.msg, "resolution"));
    CHECK("grid error: n = 1025", grid_build(&g, &m, 1025, &e) < 0 && strstr(e.msg, "1025"));
    m.positions[4] = NAN;
    CHECK("grid error: NaN vertex", grid_build(&g, &m, 32, &e) < 0 && strstr(e.msg, "non-finite"));
    m.positions[4] = INFINITY;
    CHECK("grid error: infinite vertex", grid_build(&g, &m, 32, &e) < 0 && strstr(e.msg, "non-finite"));
    m.positions[4] = 0;
    m.indices[5] = 999;
    CHECK("grid error: index out of range", grid_build(&g, &m, 32, &e) < 0 && strstr(e.msg, "999"));
    mesh_free(&m);
}

static void test_cube(void)
{
    mesh m = {0};
    mesh_add_box(&m, v3(0, 0, 0), v3(1, 1, 1), 0);
    int ns[] = {32, 48, 64, 100};
    for (int i = 0; i < 4; i++) {
        int n = ns[i];
        voxel_grid g;
        vx_err e;
        char name[128];
        if (grid_build(&g, &m, n, &e)) {
            printf("not ok grid cube build: %s\n", e.msg);
            unit_failures++;
            continue;
        }
        snprintf(name, sizeof name, "grid mapping n=%d: voxel_size = 1/(n-3), origin = -1.5 voxels", n);
        CHECK(name, fabs(g.voxel_size_d - 1.0 / (n - 3)) < 1e-15 && fabs(g.origin_d[0] + 1.5 / (n - 3)) < 1e-15 &&
                        g.origin_d[1] == g.origin_d[0] && g.origin_d[2] == g.origin_d[0]);
        /* Faces at lattice 1.5 and n - 1.5 (cell centres): cells 1..n-2 on each axis, hollow. */
        size_t k = (size_t)n - 2, want = k * k * k - (k - 2) * (k - 2) * (k - 2);
        snprintf(name, sizeof name, "grid cube n=%d: %zu voxels (shell of cells 1..n-2)", n, want);
        CHECK(name, grid_count(&g, 0) == want);
        snprintf(name, sizeof name, "grid cube n=%d: full scan agrees with count", n);
        CHECK(name, scan_count(&g, 0) == want);
        snprintf(name, sizeof name, "grid cube n=%d: MIP levels consistent", n);
        CHECK(name, mip_consistent(&g));
        snprintf(name, sizeof name, "grid cube n=%d: dense index / coordinates round trip", n);
        CHECK(name, index_roundtrip(&g));
        snprintf(name, sizeof name, "grid cube n=%d: padding cells empty", n);
        CHECK(name, grid_index(&g, 0, 0, n / 2, n / 2) < 0 && grid_index(&g, 0, n - 1, n / 2, n / 2) < 0 &&
                        grid_index(&g, 0, 1, n / 2, n / 2) >= 0 && grid_index(&g, 0, n - 2, n / 2, n / 2) >= 0);
        grid_free(&g);
    }
    mesh_free(&m);

    /* A box with unequal sides: the faces on the shorter axes land anywhere in a cell. */
    mesh_add_box(&m, v3(0, 0, 0), v3(1, 0.7f, 0.45f), 0);
    for (int i = 0; i < 4; i++) {
        int n = ns[i];
        voxel_grid g;
        vx_err e;
        if (grid_build(&g, &m, n, &e)) {
            printf("not ok grid box build: %s\n", e.msg);
            unit_failures++;
            continue;
        }
        double blo[3], bhi[3];
        grid_to_lattice(&g, v3(0, 0, 0), blo);
        grid_to_lattice(&g, v3(1, 0.7f, 0.45f), bhi);
        size_t want = box_surface_count(blo, bhi, n);
        char name[128];
        snprintf(name, sizeof name, "grid box 1x0.7x0.45 n=%d: %zu voxels", n, want);
        CHECK(name, grid_count(&g, 0) == want && scan_count(&g, 0) == want);
        grid_free(&g);
    }
    mesh_free(&m);
}

/* Two quads: A on z = 0 covering [0,29]^2 sets the bounds (voxel_size 1, origin -1.5: A lies on the
 * centres of layer 1), B on z = 10.5 = lattice 12 (exactly between layers 11 and 12) over
 * [4.5, 14.5]^2 = lattice [6, 16]^2 (its edges on cell boundaries). */
static void face_scene(mesh *m, float offset)
{
    float o = offset;
    mesh_add_quad(m, v3(o, o, o), v3(o + 29, o, o), v3(o + 29, o + 29, o), v3(o, o + 29, o), 0);
    mesh_add_quad(m, v3(o + 4.5f, o + 4.5f, o + 10.5f), v3(o + 14.5f, o + 4.5f, o + 10.5f),
                  v3(o + 14.5f, o + 14.5f, o + 10.5f), v3(o + 4.5f, o + 14.5f, o + 10.5f), 0);
}

static void test_face_on_plane(void)
{
    float offsets[] = {0.0f, 1e6f};
    for (int i = 0; i < 2; i++) {
        mesh m = {0};
        face_scene(&m, offsets[i]);
        voxel_grid g;
        vx_err e;
        char name[160];
        if (grid_build(&g, &m, 32, &e)) {
            printf("not ok face scene build: %s\n", e.msg);
            unit_failures++;
            mesh_free(&m);
            continue;
        }
        /* A: layer 1, cells 1..30 (touching [1.5, 30.5]); B: layers 11 and 12, cells 5..16. */
        int ok_a = 1, ok_b = 1, ok_out = 1;
        for (int x = 0; x < 32; x++)
            for (int y = 0; y < 32; y++) {
                int in_a = x >= 1 && x <= 30 && y >= 1 && y <= 30, in_b = x >= 5 && x <= 16 && y >= 5 && y <= 16;
                ok_a &= (grid_index(&g, 0, x, y, 1) >= 0) == in_a;
                ok_b &= (grid_index(&g, 0, x, y, 11) >= 0) == in_b && (grid_index(&g, 0, x, y, 12) >= 0) == in_b;
                ok_out &= grid_index(&g, 0, x, y, 10) < 0 && grid_index(&g, 0, x, y, 13) < 0 &&
                          grid_index(&g, 0, x, y, 0) < 0 && grid_index(&g, 0, x, y, 2) < 0;
            }
        snprintf(name, sizeof name, "grid face scene (offset %g): voxel_size 1 and origin offset-1.5", (double)offsets[i]);
        CHECK(name, g.voxel_size_d == 1.0 && g.origin_d[0] == offsets[i] - 1.5 && g.origin_d[2] == offsets[i] - 1.5);
        snprintf(name, sizeof name, "grid face scene (offset %g): quad on cell centres marks one layer", (double)offsets[i]);
        CHECK(name, ok_a);
        snprintf(name, sizeof name, "grid face scene (offset %g): quad on a cell face marks both layers, edges touching", (double)offsets[i]);
        CHECK(name, ok_b);
        snprintf(name, sizeof name, "grid face scene (offset %g): nothing else, total 900 + 288", (double)offsets[i]);
        CHECK(name, ok_out && grid_count(&g, 0) == 900 + 288);

        /* Rays in the plane z = 12 (world 10.5 + offset) along +x and -x at y = 10.5 (lattice 12):
         * the upper layer (12) by the half-open convention, cells x = 5..16. */
        float o = offsets[i];
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            grid_iter it;
            grid_hit h;
            vec3 org = v3(sgn > 0 ? o - 10 : o + 40, o + 10.5f, o + 10.5f);
            int ok = gt_iter_init(&it, &g, 0, org, v3((float)sgn, 0, 0), 0, INFINITY), x = sgn > 0 ? 5 : 16;
            int seen = 0;
            while (gt_iter_next(&it, &h)) {
                double t0, t1;
                if (sgn > 0) {
                    t0 = (x - 1.5) + 10.0;
                    t1 = t0 + 1;
                } else {
                    t0 = 40.0 - (x + 1 - 1.5);
                    t1 = t0 + 1;
                }
                ok &= h.x == x && h.y == 12 && h.z == 12 && h.t0 == (float)t0 && h.t1 == (float)t1 &&
                      h.index == grid_index(&g, 0, h.x, h.y, h.z);
                x += sgn;
                seen++;
            }
            snprintf(name, sizeof name, "grid DDA (offset %g): ray in a grid plane along %cx visits layer 12, x 5..16", (double)o,
                     sgn > 0 ? '+' : '-');
            CHECK(name, ok && seen == 12);
        }
        /* Straight down through B at lattice (10.5, 10.5): B's two layers then A, with exact t. */
        {
            grid_iter it;
            grid_hit h[8];
            int k = 0;
            gt_iter_init(&it, &g, 0, v3(o + 9, o + 9, o + 20), v3(0, 0, -2), 0, INFINITY);
            while (k < 8 && gt_iter_next(&it, &h[k]))
                k++;
            /* Lattice z of the origin is 21.5 and d = -2: layer k spans t in [(20.5-k)/2, (21.5-k)/2]. */
            int ok = k == 3 && h[0].z == 12 && h[1].z == 11 && h[2].z == 1 && h[0].x == 10 && h[0].y == 10 &&
                     h[0].t0 == 4.25f && h[0].t1 == 4.75f && h[1].t0 == 4.75f && h[1].t1 == 5.25f && h[2].t0 == 9.75f &&
                     h[2].t1 == 10.25f;
            snprintf(name, sizeof name, "grid DDA (offset %g): vertical ray hits layers 12, 11, 1 with exact t", (double)o);
            CHECK(name, ok);
            /* Shadow ray stopping between the layers: only layer 12 and part of 11. */
            gt_iter_init(&it, &g, 0, v3(o + 9, o + 9, o + 20), v3(0, 0, -2), 0, 5.0f);
            k = 0;
            while (k < 8 && gt_iter_next(&it, &h[k]))
                k++;
            snprintf(name, sizeof name, "grid DDA (offset %g): t_max clips the walk", (double)o);
            CHECK(name, k == 2 && h[1].z == 11 && h[1].t1 == 5.0f);
            /* Restart after the first hit: the same second hit. */
            gt_iter_init(&it, &g, 0, v3(o + 9, o + 9, o + 20), v3(0, 0, -2), h[0].t1, INFINITY);
            grid_hit r;
            snprintf(name, sizeof name, "grid DDA (offset %g): restart at t1 continues with the next cell", (double)o);
            CHECK(name, gt_iter_next(&it, &r) && r.z == 11 && r.t0 == 4.75f);
            /* Origin exactly on the plane z = 12 going down: starts in layer 11, not 12. */
            gt_iter_init(&it, &g, 0, v3(o + 9, o + 9, o + 10.5f), v3(0, 0, -1), 0, INFINITY);
            snprintf(name, sizeof name, "grid DDA (offset %g): origin on a plane moving down starts below it", (double)o);
            CHECK(name, gt_iter_next(&it, &r) && r.z == 11 && r.t0 == 0.0f && r.t1 == 1.0f);
        }
        grid_free(&g);
        mesh_free(&m);
    }
}

/* Shell bounds of the icosphere: every vertex within r_out of the centre and every face plane at
 * least r_in from it. */
static void sphere_shell(const mesh *m, const double c[3], double *r_in, double *r_out)
{
    *r_in = INFINITY;
    *r_out = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        double p[3][3];
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++)
                p[k][a] = m->positions[3 * m->indices[3 * t + k] + a] - c[a];
        double e1[3], e2[3], nn[3];
        for (int a = 0; a < 3; a++) {
            e1[a] = p[1][a] - p[0][a];
            e2[a] = p[2][a] - p[0][a];
        }
        nn[0] = e1[1] * e2[2] - e1[2] * e2[1];
        nn[1] = e1[2] * e2[0] - e1[0] * e2[2];
        nn[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double len = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
        *r_in = fmin(*r_in, fabs(nn[0] * p[0][0] + nn[1] * p[0][1] + nn[2] * p[0][2]) / len);
        for (int k = 0; k < 3; k++)
            *r_out = fmax(*r_out, sqrt(p[k][0] * p[k][0] + p[k][1] * p[k][1] + p[k][2] * p[k][2]));
    }
}

static void test_sphere(void)
{
    mesh m = {0};
    vec3 centre = v3(0.13f, -0.21f, 0.37f);
    add_icosphere(&m, centre, 1.0f, 3); /* 1280 triangles */
    int ns[] = {32, 48, 64, 100};
    for (int i = 0; i < 4; i++) {
        int n = ns[i];
        voxel_grid g;
        vx_err e;
        char name[160];
        double t_start = now_s();
        if (grid_build(&g, &m, n, &e)) {
            printf("not ok sphere build: %s\n", e.msg);
            unit_failures++;
            continue;
        }
        double t_build = now_s() - t_start;
        /* Sandwich against the analytic shell, in lattice units. */
        double c[3], r_in, r_out;
        grid_to_lattice(&g, centre, c);
        double cw[3] = {centre.x, centre.y, centre.z};
        sphere_shell(&m, cw, &r_in, &r_out);
        r_in /= g.voxel_size_d;
        r_out /= g.voxel_size_d;
        size_t extra = 0, missing = 0, lower = 0;
        for (int x = 0; x < n; x++)
            for (int y = 0; y < n; y++)
                for (int z = 0; z < n; z++) {
                    double dmin2 = 0, dmax2 = 0;
                    int p[3] = {x, y, z};
                    for (int a = 0; a < 3; a++) {
                        double lo = p[a] - c[a], hi = p[a] + 1 - c[a];
                        double near = lo > 0 ? lo : (hi < 0 ? -hi : 0), far = fmax(fabs(lo), fabs(hi));
                        dmin2 += near * near;
                        dmax2 += far * far;
                    }
                    double dmin = sqrt(dmin2), dmax = sqrt(dmax2);
                    int marked = grid_index(&g, 0, x, y, z) >= 0;
                    int may = dmin <= r_out + 1e-9 && dmax >= r_in - 1e-9;
                    int must = dmin < r_in - 1e-9 && dmax > r_out + 1e-9;
                    extra += marked && !may;
                    missing += must && !marked;
                    lower += must;
                }
        printf("# sphere n=%d: %zu voxels (shell lower bound %zu), built in %.2f ms\n", n, grid_count(&g, 0), lower,
               t_build * 1e3);
        snprintf(name, sizeof name, "grid sphere n=%d: every voxel meets the shell [r_in, r_out]", n);
        CHECK(name, extra == 0);
        snprintf(name, sizeof name, "grid sphere n=%d: every voxel straddling the shell is marked", n);
        CHECK(name, missing == 0 && lower > 0);
        snprintf(name, sizeof name, "grid sphere n=%d: MIP levels consistent", n);
        CHECK(name, mip_consistent(&g));
        snprintf(name, sizeof name, "grid sphere n=%d: dense index / coordinates round trip", n);
        CHECK(name, index_roundtrip(&g));

        if (n <= 48) {
            /* Brute force: every triangle against every cell, by clipping. */
            size_t cells = (size_t)n * n * n;
            unsigned char *want = calloc(cells, 1);
            for (size_t t = 0; t < m.triangle_count; t++) {
                double tri[3][3];
                for (int k = 0; k < 3; k++) {
                    const float *p = m.positions + 3 * m.indices[3 * t + k];
                    grid_to_lattice(&g, v3(p[0], p[1], p[2]), tri[k]);
                }
                for (int x = 0; x < n; x++)
                    for (int y = 0; y < n; y++)
                        for (int z = 0; z < n; z++) {
                            size_t id = ((size_t)x * n + y) * n + z;
                            if (want[id])
                                continue;
                            double lo[3] = {x, y, z}, hi[3] = {x + 1, y + 1, z + 1};
                            want[id] = (unsigned char)clip_overlap(tri, lo, hi);
                        }
            }
            size_t diff = 0;
            for (int x = 0; x < n; x++)
                for (int y = 0; y < n; y++)
                    for (int z = 0; z < n; z++)
                        diff += want[((size_t)x * n + y) * n + z] != (grid_index(&g, 0, x, y, z) >= 0);
            snprintf(name, sizeof name, "grid sphere n=%d: identical to brute-force clipping of every triangle x cell", n);
            CHECK(name, diff == 0);
            free(want);
        }
        grid_free(&g);
    }
    /* 1 thread and 2 threads give the same grid. */
    voxel_grid g1, g2;
    vx_err e;
    int ok = grid_build_threads(&g1, &m, 100, 1, &e) == 0 && grid_build_threads(&g2, &m, 100, 2, &e) == 0;
    CHECK("grid sphere: 1 and 2 threads build identical grids", ok && same_grid(&g1, &g2));
    grid_free(&g1);
    grid_free(&g2);
    mesh_free(&m);
}

static void test_degenerate(void)
{
    voxel_grid g;
    vx_err e;
    /* Planar scene: zero extent on z. */
    mesh m = {0};
    mesh_add_flat_triangle(&m, v3(0, 0, 5), v3(3, 0, 5), v3(0, 2, 5), 0);
    CHECK("grid planar scene builds", grid_build(&g, &m, 32, &e) == 0 && grid_count(&g, 0) > 0);
    {
        size_t c = 0;
        for (size_t i = 0; i < grid_count(&g, 0); i++) {
            int x, y, z;
            grid_coords(&g, 0, i, &x, &y, &z);
            c += z == 1;
        }
        CHECK("grid planar scene: one layer, on lattice z = 1.5", c == grid_count(&g, 0));
    }
    grid_free(&g);
    /* Zero-area triangles (a segment, a point) among real ones: skipped, no crash. */
    mesh_add_flat_triangle(&m, v3(0, 0, 0), v3(1, 1, 1), v3(2, 2, 2), 0);
    mesh_add_flat_triangle(&m, v3(1, 1, 1), v3(1, 1, 1), v3(1, 1, 1), 0);
    CHECK("grid with zero-area triangles builds", grid_build(&g, &m, 40, &e) == 0 && mip_consistent(&g));
    grid_free(&g);
    mesh_free(&m);
    /* Only degenerate triangles at one point: a valid, empty grid. */
    mesh_add_flat_triangle(&m, v3(1, 1, 1), v3(1, 1, 1), v3(1, 1, 1), 0);
    CHECK("grid of a single point: empty but valid", grid_build(&g, &m, 16, &e) == 0 && grid_count(&g, 0) == 0 &&
                                                          g.voxel_size_d > 0 && mip_consistent(&g));
    grid_iter it;
    grid_hit h;
    gt_iter_init(&it, &g, 0, v3(0, 0, 0), v3(1, 1, 1), 0, INFINITY);
    CHECK("grid DDA through an empty grid yields nothing", !gt_iter_next(&it, &h));
    grid_free(&g);
    mesh_free(&m);
    /* A scene far smaller than a voxel of a unit-sized grid, and one near 1e6. */
    mesh_add_flat_triangle(&m, v3(1, 1, 1), v3(1 + 1e-6f, 1, 1), v3(1, 1 + 1e-6f, 1), 0);
    CHECK("grid tiny scene builds and marks cells", grid_build(&g, &m, 64, &e) == 0 && grid_count(&g, 0) > 0 &&
                                                        mip_consistent(&g));
    grid_free(&g);
    mesh_free(&m);
    mesh_add_flat_triangle(&m, v3(1e6f, 1e6f, 1e6f), v3(1e6f + 0.25f, 1e6f, 1e6f), v3(1e6f, 1e6f + 0.5f, 1e6f + 0.125f), 0);
    int ok = grid_build(&g, &m, 64, &e) == 0 && grid_count(&g, 0) > 0;
    double p[3];
    if (ok)
        grid_to_lattice(&g, v3(1e6f, 1e6f, 1e6f), p);
    CHECK("grid scene near 1e6: minimum vertex at lattice 1.5", ok && fabs(p[0] - 1.5) < 1e-6 && fabs(p[1] - 1.5) < 1e-6 && fabs(p[2] - 1.5) < 1e-6);
    grid_free(&g);
    mesh_free(&m);
    /* Tiny resolutions (test-only range). */
    mesh_add_box(&m, v3(0, 0, 0), v3(1, 1, 1), 0);
    int tiny_ok = 1;
    for (int n = 1; n <= 5; n++) {
        tiny_ok &= grid_build(&g, &m, n, &e) == 0 && grid_count(&g, 0) > 0 && mip_consistent(&g) && index_roundtrip(&g);
        grid_free(&g);
    }
    CHECK("grid builds at n = 1..5", tiny_ok);
    mesh_free(&m);
}

/* ---------- traversal against a brute-force slab test of every non-empty cell ---------- */

typedef struct {
    int x, y, z;
    double t0, t1, len;
} slab_hit;

static int cmp_slab(const void *a, const void *b)
{
    double x = ((const slab_hit *)a)->t0, y = ((const slab_hit *)b)->t0;
    return x < y ? -1 : x > y;
}

/* Overlap of the ray with cell (x,y,z) of `level` in [tmin, tmax]; len in lattice units of the
 * level (negative when the ray misses the cell). On an axis with a zero direction component the
 * cell is the half-open [c, c+1). */
static slab_hit slab(const double o[3], const double d[3], int x, int y, int z, double tmin, double tmax)
{
    slab_hit h = {x, y, z, tmin, tmax, 0};
    int p[3] = {x, y, z};
    double dl = 0;
    for (int a = 0; a < 3; a++) {
        dl += d[a] * d[a];
        if (d[a] == 0) {
            if (!(o[a] >= p[a] && o[a] < p[a] + 1))
                h.t1 = -INFINITY;
            continue;
        }
        double ta = (p[a] - o[a]) / d[a], tb = (p[a] + 1 - o[a]) / d[a];
        if (ta > tb) {
            double s = ta;
            ta = tb;
            tb = s;
        }
        h.t0 = fmax(h.t0, ta);
        h.t1 = fmin(h.t1, tb);
    }
    h.len = (h.t1 - h.t0) * sqrt(dl);
    return h;
}

/* Runs one ray at `level` both ways; returns 0 on any disagreement (and prints why). */
static int check_ray(const voxel_grid *g, int level, vec3 org, vec3 dir, float tmin, float tmax, slab_hit *buf,
                     size_t bufcap)
{
    double scale = ldexp(g->voxel_size_d, level), o[3], d[3] = {dir.x / scale, dir.y / scale, dir.z / scale};
    grid_to_lattice(g, org, o);
    for (int a = 0; a < 3; a++)
        o[a] /= ldexp(1.0, level);
    size_t nb = 0;
    for (size_t i = 0; i < grid_count(g, level); i++) {
        int x, y, z;
        grid_coords(g, level, i, &x, &y, &z);
        slab_hit h = slab(o, d, x, y, z, tmin, tmax);
        if (h.len > 1e-6 && nb < bufcap)
            buf[nb++] = h;
    }
    qsort(buf, nb, sizeof *buf, cmp_slab);
    grid_iter it;
    grid_hit h;
    gt_iter_init(&it, g, level, org, dir, tmin, tmax);
    size_t j = 0;
    double last_t1 = -INFINITY;
    int steps = 0;
    while (gt_iter_next(&it, &h)) {
        if (++steps > 100000) {
            printf("# runaway traversal\n");
            return 0;
        }
        if (h.index != grid_index(g, level, h.x, h.y, h.z) || h.index < 0 || !(h.t0 <= h.t1) || h.t0 < last_t1 ||
            h.t0 < tmin || h.t1 > tmax) {
            printf("# bad hit %d %d %d index %lld t %g %g (last t1 %g)\n", h.x, h.y, h.z, (long long)h.index, (double)h.t0,
                   (double)h.t1, last_t1);
            return 0;
        }
        last_t1 = h.t1;
        slab_hit s = slab(o, d, h.x, h.y, h.z, tmin, tmax);
        if (s.len < -1e-6) {
            printf("# DDA cell %d %d %d not on the ray (len %g)\n", h.x, h.y, h.z, s.len);
            return 0;
        }
        if (s.len <= 1e-6)
            continue; /* a grazing cell: either answer is right */
        if (j >= nb || buf[j].x != h.x || buf[j].y != h.y || buf[j].z != h.z) {
            printf("# DDA cell %d %d %d, brute force expects %d %d %d (%zu of %zu)\n", h.x, h.y, h.z,
                   j < nb ? buf[j].x : -1, j < nb ? buf[j].y : -1, j < nb ? buf[j].z : -1, j, nb);
            return 0;
        }
        double tol = 1e-5 * (1.0 + fabs(s.t1)) + 1e-9;
        if (fabs(h.t0 - s.t0) > tol || fabs(h.t1 - s.t1) > tol) {
            printf("# DDA cell %d %d %d t [%.9g %.9g], slab [%.9g %.9g]\n", h.x, h.y, h.z, (double)h.t0, (double)h.t1, s.t0,
                   s.t1);
            return 0;
        }
        j++;
    }
    if (j != nb) {
        printf("# DDA found %zu cells, brute force %zu\n", j, nb);
        return 0;
    }
    /* The same walk from the origin mapped beforehand (the frame's primary rays, from the camera's
     * lattice point): the same cells with the same [t0, t1], bit for bit. */
    grid_iter from_world, from_lattice;
    grid_hit a, b;
    double lattice[3];
    gt_lattice_point(g, level, org, lattice);
    int na = gt_iter_init(&from_world, g, level, org, dir, tmin, tmax);
    int nl = gt_iter_init_lattice(&from_lattice, g, level, lattice, dir, tmin, tmax);
    for (steps = 0; na == nl && na && steps < 100000; steps++) {
        na = gt_iter_next(&from_world, &a);
        nl = gt_iter_next(&from_lattice, &b);
        if (na && nl && (a.x != b.x || a.y != b.y || a.z != b.z || a.index != b.index || a.t0 != b.t0 || a.t1 != b.t1)) {
            printf("# walk from the lattice point: cell %d %d %d [%.9g %.9g], from the world origin %d %d %d [%.9g %.9g]\n",
                   b.x, b.y, b.z, (double)b.t0, (double)b.t1, a.x, a.y, a.z, (double)a.t0, (double)a.t1);
            return 0;
        }
    }
    if (na != nl) {
        printf("# walk from the lattice point ends %s the walk from the world origin\n", nl ? "after" : "before");
        return 0;
    }
    return 1;
}

/* gt_cell_at_exit, the walk's starting cell on one axis and its exit plane, against brute force:
 * for random origins and directions (both signs, lengths from 1e-3 to 1e3 lattice units), at t on
 * a lattice plane and one ulp either side, the cell must be the one the ray occupies just after t
 * by the planes' own distances (s > 0: the last plane at or before t; s < 0: the first whose next
 * plane is at or before t; clamped to [lo, hi]), and the exit the distance gt_exit_t gives for it,
 * bit for bit. The floor of o + t d only guesses the cell; the check also counts the guesses that
 * had to be corrected up and down, for each sign, so that the corrections (where the exit plane is
 * carried along) are shown to be reached. */
static void test_cell_at_exit(void)
{
    enum { N = 64 };
    rng r = rng_seed(20261206, 1);
    long wrong_cell = 0, wrong_exit = 0, corrected[2][2] = {{0, 0}, {0, 0}}; /* [s > 0][up] */
    for (int trial = 0; trial < 400000; trial++) {
        grid_iter it;
        memset(&it, 0, sizeof it);
        double len = pow(10.0, -3.0 + 6.0 * rng_float(&r));
        int s = rng_float(&r) < 0.5f ? -1 : 1;
        it.o[0] = -8.0 + (N + 16.0) * rng_float(&r) + ldexp(rng_float(&r), -20);
        it.d[0] = s * len * (1.0 + rng_float(&r) / 3.0);
        it.inv[0] = 1.0 / it.d[0];
        it.dir[0] = s;
        int k = (int)(rng_float(&r) * (N + 1));
        double t = gt_plane_t(&it, 0, k);
        int side = (int)(rng_float(&r) * 3.0f);
        if (side == 1)
            t = nextafter(t, -INFINITY);
        else if (side == 2)
            t = nextafter(t, INFINITY);
        double t_exit;
        int c = gt_cell_at_exit(&it, 0, t, 0, N - 1, &t_exit);
        int want = s > 0 ? 0 : N - 1;
        if (s > 0) {
            for (int q = 1; q < N; q++)
                if (gt_plane_t(&it, 0, q) <= t)
                    want = q;
        } else {
            for (int q = N - 1; q >= 0; q--)
                if (gt_plane_t(&it, 0, q + 1) <= t)
                    want = q;
        }
        double want_exit = gt_exit_t(&it, 0, want, 0);
        wrong_cell += c != want;
        wrong_exit += memcmp(&t_exit, &want_exit, sizeof t_exit) != 0;
        /* The guess gt_cell_at_exit starts from (its own rule, restated). */
        double p = it.o[0] + t * it.d[0];
        int guess = !(p >= 0.0) ? 0 : (p >= N ? N - 1 : (int)p);
        if (s < 0 && p >= 0.0 && p < N && guess == p && guess > 0)
            guess--;
        if (guess != c)
            corrected[s > 0][c > guess]++;
    }
    char name[200];
    snprintf(name, sizeof name, "gt_cell_at_exit: the brute-force cell in 400000 trials (%ld wrong)", wrong_cell);
    CHECK(name, wrong_cell == 0);
    snprintf(name, sizeof name, "gt_cell_at_exit: its exit is gt_exit_t's, bit for bit (%ld wrong)", wrong_exit);
    CHECK(name, wrong_exit == 0);
    snprintf(name, sizeof name,
             "gt_cell_at_exit: guesses corrected, s > 0 up %ld / down %ld, s < 0 up %ld / down %ld (each > 0)",
             corrected[1][1], corrected[1][0], corrected[0][1], corrected[0][0]);
    CHECK(name, corrected[1][1] > 0 && corrected[1][0] > 0 && corrected[0][1] > 0 && corrected[0][0] > 0);
}

static void test_traversal(void)
{
    mesh m = {0};
    add_icosphere(&m, v3(0.13f, -0.21f, 0.37f), 1.0f, 3);
    mesh_add_box(&m, v3(-0.3f, -0.2f, 0.1f), v3(0.4f, 0.3f, 0.6f), 0); /* something inside too */
    mesh_add_flat_triangle(&m, v3(-1.5f, -1.5f, -0.9f), v3(1.8f, -1.5f, -0.9f), v3(-1.5f, 1.7f, -0.9f), 0);
    int ns[] = {48, 37};
    slab_hit *buf = malloc(100000 * sizeof *buf);
    for (int ni = 0; ni < 2; ni++) {
        voxel_grid g;
        vx_err e;
        if (grid_build(&g, &m, ns[ni], &e)) {
            printf("not ok traversal build: %s\n", e.msg);
            unit_failures++;
            continue;
        }
        float ext = g.voxel_size * g.n;
        rng r = rng_seed(11, (uint64_t)ns[ni]);
        for (int level = 0; level < 4; level++) {
            int bad = 0, rays = 600;
            for (int i = 0; i < rays && !bad; i++) {
                vec3 org = v3(g.origin.x + ext * (float)(rng_double(&r) * 1.6 - 0.3),
                              g.origin.y + ext * (float)(rng_double(&r) * 1.6 - 0.3),
                              g.origin.z + ext * (float)(rng_double(&r) * 1.6 - 0.3));
                vec3 dir = v3((float)(rng_double(&r) * 2 - 1), (float)(rng_double(&r) * 2 - 1),
                              (float)(rng_double(&r) * 2 - 1));
                int kind = i % 10;
                if (kind == 1)
                    dir.x = 0;
                if (kind == 2)
                    dir.y = dir.z = 0;
                if (kind == 3) {
                    /* Aim at a random non-empty cell so that most rays hit something. */
                    int x, y, z;
                    grid_coords(&g, 0, (size_t)(rng_double(&r) * grid_count(&g, 0)), &x, &y, &z);
                    dir = v3_sub(grid_cell_center(&g, 0, x, y, z), org);
                }
                if (kind == 4) {
                    /* Origin on a lattice plane, moving along it. */
                    org.z = g.origin.z + g.voxel_size * 20;
                    dir.z = 0;
                }
                float tmin = kind == 5 ? (float)rng_double(&r) * ext : 0.0f;
                float tmax = kind >= 6 ? (float)rng_double(&r) * ext * 2 : INFINITY;
                if (!check_ray(&g, level, org, dir, tmin, tmax, buf, 100000)) {
                    printf("# ray %d: org %.9g %.9g %.9g dir %.9g %.9g %.9g t [%g %g]\n", i, (double)org.x, (double)org.y,
                           (double)org.z, (double)dir.x, (double)dir.y, (double)dir.z, (double)tmin, (double)tmax);
                    bad = 1;
                }
            }
            char name[128];
            snprintf(name, sizeof name, "grid DDA n=%d level %d: %d random rays match brute-force slab tests", ns[ni], level,
                     rays);
            CHECK(name, !bad);
        }
        /* Misses and degenerate rays. */
        grid_iter it;
        grid_hit h;
        vec3 far = v3(g.origin.x - ext, g.origin.y - ext, g.origin.z - ext);
        CHECK("grid DDA: ray pointing away misses", !gt_iter_init(&it, &g, 0, far, v3(-1, -1, -1), 0, INFINITY) &&
                                                       !gt_iter_next(&it, &h));
        CHECK("grid DDA: zero direction yields nothing", !gt_iter_init(&it, &g, 0, g.origin, v3(0, 0, 0), 0, INFINITY));
        CHECK("grid DDA: NaN direction yields nothing", !gt_iter_init(&it, &g, 0, g.origin, v3(NAN, 1, 0), 0, INFINITY));
        CHECK("grid DDA: invalid level yields nothing", !gt_iter_init(&it, &g, g.levels, g.origin, v3(1, 1, 1), 0, INFINITY));
        CHECK("grid DDA: axis ray outside the slab misses",
              !gt_iter_init(&it, &g, 0, v3(far.x, g.origin.y + ext * 0.5f, g.origin.z + ext * 1.5f), v3(1, 0, 0), 0, INFINITY));
        grid_free(&g);
    }
    free(buf);
    mesh_free(&m);
}

/* ---------- the bunny: memory and speed ---------- */

static void test_bunny(void)
{
    const char *path = "/work/shared/data/meshes/bunny.ply";
    mesh m = {0};
    if (load_bunny(path, &m)) {
        printf("ok grid bunny # SKIP %s not readable\n", path);
        mesh_free(&m);
        return;
    }
    printf("# bunny: %zu triangles\n", m.triangle_count);
    int ns[] = {128, 256, 512};
    for (int i = 0; i < 3; i++) {
        voxel_grid g;
        vx_err e;
        double best = INFINITY;
        int ok = 1;
        for (int rep = 0; rep < 3 && ok; rep++) {
            double t0 = now_s();
            ok = grid_build(&g, &m, ns[i], &e) == 0;
            best = fmin(best, now_s() - t0);
            if (ok && rep < 2)
                grid_free(&g);
        }
        char name[128];
        snprintf(name, sizeof name, "grid bunny n=%d builds", ns[i]);
        CHECK(name, ok);
        if (!ok) {
            printf("# %s\n", e.msg);
            continue;
        }
        size_t bytes = grid_bytes(&g);
        double t1 = now_s();
        voxel_grid g1;
        grid_build_threads(&g1, &m, ns[i], 1, &e);
        double single = now_s() - t1;
        printf("# bunny n=%d: %zu voxels (%.2f%% of n^3), %zu stored words, %d levels, %.2f MB, build %.1f ms "
               "(2 threads; 1 thread %.1f ms)\n",
               ns[i], grid_count(&g, 0), 100.0 * grid_count(&g, 0) / ((double)ns[i] * ns[i] * ns[i]), g.level[0].words,
               g.levels, bytes / 1e6, best * 1e3, single * 1e3);
        snprintf(name, sizeof name, "grid bunny n=%d: 1 and 2 threads identical", ns[i]);
        CHECK(name, same_grid(&g, &g1));
        grid_free(&g1);
        if (ns[i] == 128) {
            /* Realistic geometry for the traversal: rays through the bunny against brute force. */
            slab_hit *buf = malloc(200000 * sizeof *buf);
            rng rr = rng_seed(5, 128);
            vec3 c = grid_cell_center(&g, 0, 64, 64, 64);
            float ext = g.voxel_size * g.n;
            int bad = 0;
            for (int k = 0; k < 300 && !bad; k++) {
                vec3 a = v3((float)rng_double(&rr) - 0.5f, (float)rng_double(&rr) - 0.5f, (float)rng_double(&rr) - 0.5f);
                vec3 b = v3((float)rng_double(&rr) - 0.5f, (float)rng_double(&rr) - 0.5f, (float)rng_double(&rr) - 0.5f);
                vec3 org = v3_madd(c, a, ext * (k % 2 ? 0.6f : 2.0f));
                vec3 dir = v3_sub(v3_madd(c, b, ext * 0.5f), org);
                bad = !check_ray(&g, k % 3, org, dir, 0, INFINITY, buf, 200000);
            }
            CHECK("grid bunny n=128: DDA (levels 0-2) matches brute force on 300 rays", !bad);
            free(buf);
        }
        if (ns[i] == 512) {
            CHECK("grid bunny n=512: memory under 200 MB", bytes < 200u * 1000u * 1000u);
            CHECK("grid bunny n=512: MIP levels consistent", mip_consistent(&g));
            CHECK("grid bunny n=512: dense index round trip", index_roundtrip(&g));
        }
        /* DDA speed: rays from outside toward random points of the bunny's box, all hits. */
        rng r = rng_seed(3, (uint64_t)ns[i]);
        const int rays = 200000;
        vec3 centre = grid_cell_center(&g, 0, g.n / 2, g.n / 2, g.n / 2);
        float ext = g.voxel_size * g.n;
        vec3 *org = malloc(rays * sizeof *org), *dir = malloc(rays * sizeof *dir);
        for (int k = 0; k < rays; k++) {
            vec3 a = v3((float)rng_double(&r) - 0.5f, (float)rng_double(&r) - 0.5f, (float)rng_double(&r) - 0.5f);
            vec3 b = v3((float)rng_double(&r) - 0.5f, (float)rng_double(&r) - 0.5f, (float)rng_double(&r) - 0.5f);
            org[k] = v3_madd(centre, v3_normalize(a), ext * 1.5f);
            dir[k] = v3_sub(v3_madd(centre, b, ext * 0.6f), org[k]);
        }
        size_t visited = 0, first_hits = 0;
        double t0 = now_s();
        for (int k = 0; k < rays; k++) {
            grid_iter it;
            grid_hit h;
            gt_iter_init(&it, &g, 0, org[k], dir[k], 0, INFINITY);
            int first = 1;
            while (gt_iter_next(&it, &h)) {
                visited++;
                first_hits += first;
                first = 0;
            }
        }
        double all = now_s() - t0;
        t0 = now_s();
        size_t any = 0;
        for (int k = 0; k < rays; k++) {
            grid_iter it;
            grid_hit h;
            gt_iter_init(&it, &g, 0, org[k], dir[k], 0, INFINITY);
            any += (size_t)gt_iter_next(&it, &h);
        }
        double first_only = now_s() - t0;
        printf("# bunny n=%d DDA: %d rays, %.1f%% hit, %.1f voxels per hitting ray; all voxels %.0f ns/ray, "
               "first voxel only %.0f ns/ray\n",
               ns[i], rays, 100.0 * first_hits / rays, first_hits ? (double)visited / first_hits : 0.0, all / rays * 1e9,
               first_only / rays * 1e9);
        free(org);
        free(dir);
        grid_free(&g);
    }
    /* A huge ground plate under the bunny: must stay fast (about n^2 tests, not n^3). */
    double t0 = now_s();
    mesh_add_quad(&m, v3(-1, -0.1f, -1), v3(-1, -0.1f, 1), v3(1, -0.1f, 1), v3(1, -0.1f, -1), 0);
    voxel_grid g;
    vx_err e;
    int ok = grid_build(&g, &m, 512, &e) == 0;
    printf("# bunny + 2x2 ground plate n=512: %zu voxels, %.1f ms, %.2f MB\n", ok ? grid_count(&g, 0) : 0,
           (now_s() - t0) * 1e3, ok ? grid_bytes(&g) / 1e6 : 0.0);
    CHECK("grid bunny + ground plate n=512 builds", ok);
    grid_free(&g);
    mesh_free(&m);
}

/* The cone marcher's dilated occupancy (cone_skip.h) against a brute-force 3x3x3 search of the
 * sparse grid, on every cell of every level and the one-cell border around it (sizes around the
 * 64-cell word boundaries). */
static void test_dilated(void)
{
    mesh m = {0};
    add_icosphere(&m, v3(0.13f, -0.21f, 0.37f), 1.0f, 3);
    int ns[] = {48, 64, 65, 100};
    for (int i = 0; i < 4; i++) {
        voxel_grid g;
        vx_err e;
        dilated_grid d;
        if (grid_build(&g, &m, ns[i], &e) || dilated_build(&d, &g)) {
            printf("not ok dilated build n=%d\n", ns[i]);
            unit_failures++;
            continue;
        }
        long wrong = 0, marked = 0;
        for (int l = 0; l < g.levels; l++) {
            int n = g.level[l].n;
            for (int x = -1; x <= n; x++)
                for (int y = -1; y <= n; y++)
                    for (int z = -1; z <= n; z++) {
                        int any = 0;
                        for (int k = 0; k < 27 && !any; k++)
                            any = grid_index(&g, l, x + k / 9 - 1, y + (k / 3) % 3 - 1, z + k % 3 - 1) >= 0;
                        marked += any;
                        wrong += any != dilated_any(&d, l, x, y, z);
                    }
            wrong += dilated_any(&d, l, -2, 0, 0) + dilated_any(&d, l, 0, n + 1, 0); /* beyond the border */
        }
        char name[96];
        snprintf(name, sizeof name, "dilated occupancy n=%d matches a 3x3x3 search (%ld marked)", ns[i], marked);
        CHECK(name, wrong == 0 && marked > 0);
        dilated_free(&d);
        grid_free(&g);
    }
    mesh_free(&m);
}

/* Issue 19: at 1024^3 a grid's memory follows the surface, not the volume. A square plate of side
 * s (a quarter, half and all of the lattice's width, the lattice fixed by explicit bounds) gives
 * grid_bytes growing with s^2 beyond a constant (the N^2 column tables): the increments from
 * s = 1/4 to 1/2 and from 1/2 to 1 are in the ratio of the areas' increments, 4, and the whole
 * grid stays far below the N^3 / 8 bytes of one dense bit level. */
static void test_plane_memory(void)
{
    const int n = 1024;
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    size_t bytes[3], voxels[3];
    for (int i = 0; i < 3; i++) {
        float side = 0.25f * (float)(1 << i);
        mesh m;
        memset(&m, 0, sizeof m);
        vec3 a = v3(0, 0.5f, 0), b = v3(side, 0.5f, 0), c = v3(side, 0.5f, side), d = v3(0, 0.5f, side);
        mesh_add_flat_triangle(&m, a, b, c, 0);
        mesh_add_flat_triangle(&m, a, c, d, 0);
        voxel_grid g;
        vx_err e;
        if (grid_build_bounds(&g, &m, n, lo, hi, &e)) {
            printf("# %s\n", e.msg);
            CHECK("1024^3 plate: the grid builds", 0);
            mesh_free(&m);
            return;
        }
        bytes[i] = grid_bytes(&g);
        voxels[i] = grid_count(&g, 0);
        printf("# 1024^3 plate of side %.2f: %zu voxels, %zu grid bytes\n", side, voxels[i], bytes[i]);
        grid_free(&g);
        mesh_free(&m);
    }
    double ratio = (double)(bytes[2] - bytes[1]) / (double)(bytes[1] - bytes[0]);
    CHECK_NEAR("1024^3 plate: grid bytes grow with the area (increments 1/2 -> 1 over 1/4 -> 1/2: 4)", ratio, 4.0, 0.2);
    CHECK_NEAR("1024^3 plate: level-0 voxels grow with the area (same ratio)",
               (double)(voxels[2] - voxels[1]) / (double)(voxels[1] - voxels[0]), 4.0, 0.1);
    CHECK("1024^3 plate: the whole grid (every level) stays below a fifth of one dense bit level (N^3 / 8 bytes)",
          bytes[2] < (size_t)n * n * n / 8 / 5);
}

/* Every array of every level equal, byte for byte (including the first-word field of empty columns). */
static int identical_arrays(const voxel_grid *a, const voxel_grid *b)
{
    if (a->n != b->n || a->levels != b->levels || a->voxel_size_d != b->voxel_size_d ||
        memcmp(a->origin_d, b->origin_d, sizeof a->origin_d) != 0)
        return 0;
    for (int l = 0; l < a->levels; l++) {
        const grid_level *A = &a->level[l], *B = &b->level[l];
        size_t cols = (size_t)A->n * (size_t)A->n;
        if (A->n != B->n || A->words_per_col != B->words_per_col || A->words != B->words || A->count != B->count ||
            memcmp(A->cols, B->cols, cols * sizeof *A->cols) || memcmp(A->bits, B->bits, A->words * sizeof *A->bits) ||
            memcmp(A->prefix, B->prefix, A->words * sizeof *A->prefix) ||
            memcmp(A->coords, B->coords, A->count * sizeof *A->coords) || !A->dense != !B->dense ||
            (A->dense && memcmp(A->dense, B->dense, cols * (size_t)A->words_per_col * sizeof *A->dense)))
            return 0;
    }
    return 1;
}

/* The coarse levels' plain bits (grid_level.dense) are kept exactly where grid.h says (levels 1 and
 * up whose n^2 ceil(n / 64) words fit in GRID_DENSE_MAX_BYTES) and hold each column's words as the
 * sparse form has them, found here by the mask's popcount rather than in storage order. */
static int dense_bits_as_documented(const voxel_grid *g)
{
    for (int l = 0; l < g->levels; l++) {
        const grid_level *L = &g->level[l];
        size_t cols = (size_t)L->n * (size_t)L->n, W = (size_t)L->words_per_col;
        int expected = l > 0 && cols * W * sizeof(uint64_t) <= GRID_DENSE_MAX_BYTES;
        if (!L->dense != !expected)
            return 0;
        for (size_t c = 0; L->dense && c < cols; c++)
            for (size_t j = 0; j < W; j++) {
                uint64_t mask = L->cols[c] & 0xffffu, want = 0;
                if ((mask >> j) & 1u)
                    want = L->bits[(L->cols[c] >> 16) + (uint64_t)__builtin_popcountll(mask & ((UINT64_C(1) << j) - 1u))];
                if (L->dense[c * W + j] != want)
                    return 0;
            }
    }
    return 1;
}

static void mesh_lo_hi(const mesh *m, double lo[3], double hi[3])
{
    for (int a = 0; a < 3; a++)
        lo[a] = INFINITY, hi[a] = -INFINITY;
    for (size_t v = 0; v < m->vertex_count; v++)
        for (int a = 0; a < 3; a++)
            lo[a] = fmin(lo[a], m->positions[3 * v + a]), hi[a] = fmax(hi[a], m->positions[3 * v + a]);
}

/* The grid rebuilt from a grid's level-0 list (a .vox file's) is the voxelised one, array for
 * array, at sizes that leave partial MIP blocks and partial 64-cell words; a random set of cells
 * agrees with the dense builder (grid_build_cells given the cells out of order and some twice, which
 * takes its n^3 bit array) and with brute-force MIP levels, and grid_build_cells given them in order
 * (its sparse path, tracer/dynamic/'s case) builds the same; a list out of order, repeated or
 * outside the grid is refused by grid_build_sorted_cells with the cell named. */
static void test_sorted_cells(void)
{
    mesh m = {0};
    add_icosphere(&m, v3(0.1f, -0.2f, 0.3f), 1.0f, 3);
    add_icosphere(&m, v3(1.6f, 0.4f, -0.5f), 0.35f, 2);
    double lo[3], hi[3];
    mesh_lo_hi(&m, lo, hi);
    int ns[] = {1, 2, 3, 5, 7, 64, 65, 100, 129, 300, 1024};
    for (size_t i = 0; i < sizeof ns / sizeof *ns; i++) {
        voxel_grid g, r;
        vx_err e;
        char name[128];
        snprintf(name, sizeof name, "grid from sorted cells n=%d: identical to the voxelised grid", ns[i]);
        int ok = grid_build(&g, &m, ns[i], &e) == 0;
        ok = ok && grid_build_sorted_cells(&r, ns[i], lo, hi, g.level[0].coords, g.level[0].count, &e) == 0;
        CHECK(name, ok && identical_arrays(&g, &r));
        snprintf(name, sizeof name, "grid n=%d: the coarse levels' plain bits where grid.h says, equal to the sparse words",
                 ns[i]);
        CHECK(name, ok && dense_bits_as_documented(&g) && dense_bits_as_documented(&r));
        if (ok)
            grid_free(&r);
        grid_free(&g);
    }

    /* Random cells at n = 100: 3 levels of partial blocks, sparse and dense. */
    voxel_grid like, dense, sparse;
    vx_err e;
    int n = 100;
    if (grid_build(&like, &m, n, &e) != 0) {
        CHECK("grid from sorted cells: random set (mapping)", 0);
        mesh_free(&m);
        return;
    }
    size_t count = 0;
    uint32_t *cells = malloc((size_t)n * n * n / 7 * sizeof *cells);
    uint64_t state = 12345;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++)
            for (int z = 0; z < n; z++) {
                state = state * 6364136223846793005ULL + 1442695040888963407ULL;
                /* Dense in a slab, sparse elsewhere: full words, single bits and empty columns. */
                int keep = x > 40 && x < 47 ? (state >> 33) % 2 == 0 : (state >> 33) % 997 == 0;
                if (keep)
                    cells[count++] = (uint32_t)x << 20 | (uint32_t)y << 10 | (uint32_t)z;
            }
    /* The dense builder's input: reversed, with every tenth cell listed twice. */
    uint32_t *shuffled = malloc((count + count / 10 + 1) * sizeof *shuffled);
    size_t shuffled_count = 0;
    for (size_t i = count; shuffled && i-- > 0;) {
        shuffled[shuffled_count++] = cells[i];
        if (i % 10 == 0)
            shuffled[shuffled_count++] = cells[i];
    }
    voxel_grid in_order;
    int ok = shuffled && grid_build_cells(&dense, &like, shuffled, shuffled_count, &e) == 0;
    ok = ok && grid_build_sorted_cells(&sparse, n, lo, hi, cells, count, &e) == 0;
    int ok_in_order = ok && grid_build_cells(&in_order, &like, cells, count, &e) == 0;
    CHECK("grid from sorted cells: a random set equals the dense builder's grid", ok && identical_arrays(&dense, &sparse));
    CHECK("grid from sorted cells: MIP levels equal brute force, indices round-trip",
          ok && mip_consistent(&sparse) && index_roundtrip(&sparse) && grid_count(&sparse, 0) == count);
    CHECK("grid_build_cells: cells in order (built sparse) give the dense builder's grid",
          ok_in_order && identical_arrays(&dense, &in_order) && in_order.voxel_size_d == like.voxel_size_d &&
              memcmp(in_order.origin_d, like.origin_d, sizeof like.origin_d) == 0);
    if (ok_in_order)
        grid_free(&in_order);
    if (ok) {
        grid_free(&dense);
        grid_free(&sparse);
    }
    free(shuffled);
    grid_free(&like);

    uint32_t swapped[3] = {cells[0], cells[2], cells[1]}, twice[2] = {cells[0], cells[0]};
    uint32_t outside[2] = {cells[0], (uint32_t)5 << 20 | (uint32_t)(n + 1) << 10 | 3u};
    CHECK("grid from sorted cells: out of order is refused, naming the cell",
          grid_build_sorted_cells(&sparse, n, lo, hi, swapped, 3, &e) < 0 && strstr(e.msg, "cell 2,") &&
              strstr(e.msg, "order") && sparse.levels == 0);
    CHECK("grid from sorted cells: a cell listed twice is refused",
          grid_build_sorted_cells(&sparse, n, lo, hi, twice, 2, &e) < 0 && strstr(e.msg, "cell 1,"));
    CHECK("grid from sorted cells: a cell outside the grid is refused",
          grid_build_sorted_cells(&sparse, n, lo, hi, outside, 2, &e) < 0 && strstr(e.msg, "(5, 101, 3)") &&
              strstr(e.msg, "outside"));
    CHECK("grid from sorted cells: n = 1025 is refused", grid_build_sorted_cells(&sparse, 1025, lo, hi, cells, 1, &e) < 0);
    CHECK("grid from sorted cells: no cells is a valid (empty) grid",
          grid_build_sorted_cells(&sparse, n, lo, hi, cells, 0, &e) == 0 && grid_count(&sparse, 0) == 0 &&
              grid_index(&sparse, 0, 1, 2, 3) < 0);
    grid_free(&sparse);
    free(cells);
    mesh_free(&m);
}

int main(void)
{
    test_tribox();
    test_errors();
    test_cube();
    test_face_on_plane();
    test_sphere();
    test_degenerate();
    test_cell_at_exit();
    test_traversal();
    test_dilated();
    test_bunny();
    test_plane_memory();
    test_sorted_cells();
    return unit_exit();
}
