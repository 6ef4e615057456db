/* The shared bake sampler (tracer/bake/bake.h) against independent expectations.
 *
 * Generation: directions uniform on the sphere (mean 0, second moment I/3); origins outside the
 * scene's bounding sphere; [t_entry, t_exit] equal to a double-precision slab test of the line
 * against the voxel; lines uniform over the voxel's projection, checked through their entry points:
 * each axis's pair of faces takes 1/3 of the lines (E|w_k| / E(|w_x|+|w_y|+|w_z|)), and the entry
 * points on a face are uniform over it (mean, variance 1/12, no correlation, a 4x4 chi-square); the
 * mean chord length is the voxel size times E[1 / (|w_x|+|w_y|+|w_z|)] (the mean of V / projected
 * area), computed here by quadrature. Seeds and voxel indices select independent streams.
 *
 * Uniform directions with lines uniform over the projection is the sampler's documented measure; it
 * is not the area-weighted one of isotropic uniform random lines (whose mean chord would be Cauchy's
 * 4V/S = 2/3 of the size), and the chord check is tight enough to tell the two apart.
 *
 * Classification: the fractions of INSIDE_FRONT / INSIDE_BACK / OUTSIDE / MISS samples for a voxel
 * of a quad (axis-aligned and tilted) and of a closed box are compared with a Monte Carlo reference
 * written here: its own random numbers, its own way of drawing the same line measure (a visible
 * face picked with probability proportional to its projected area, a uniform point on it) and its
 * own line/plane and line/box intersections. A plane through the whole voxel is crossed inside it
 * by exactly 1/3 of the lines (E|w_z| / |w|_1 = 1/3 by symmetry; Crofton's 2a^2 / 6a^2 for the
 * area-weighted measure too). Front and back follow the triangles' winding; a triangle
 * lying exactly on the face between two voxels (grid.h: both are non-empty) is INSIDE for both. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "grid.h"
#include "mesh.h"
#include "rt.h"
#include "scene.h"
#include "tribox.h"
#include "unit.h"

/* ---------- the test's own random numbers (xorshift64*, not tracer/core/rng.h) ---------- */

static uint64_t rnd_u64(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return *s * 0x2545F4914F6CDD1DULL;
}
static double rnd01(uint64_t *s) { return (double)(rnd_u64(s) >> 11) * (1.0 / 9007199254740992.0); }

/* Uniform on the sphere as a normalised Gaussian vector (the sampler uses z and phi instead). */
static void rnd_dir(uint64_t *s, double d[3])
{
    for (;;) {
        double len2 = 0;
        for (int k = 0; k < 3; k++) {
            double u = rnd01(s), v = rnd01(s);
            d[k] = sqrt(-2.0 * log(u + 1e-300)) * cos(2.0 * M_PI * v);
            len2 += d[k] * d[k];
        }
        if (len2 > 1e-12) {
            double inv = 1.0 / sqrt(len2);
            for (int k = 0; k < 3; k++)
                d[k] *= inv;
            return;
        }
    }
}

/* ---------- a hand-built scene ---------- */

typedef struct {
    scene s;
    material mat;
    light sun;
    rt_scene rt;
    voxel_grid g;
} world;

/* Takes the mesh already in w->s.mesh; one material, one light, bounds from the vertices. */
static int world_build(world *w, int n, int double_sided)
{
    w->mat = (material){.color = v3(0.8f, 0.6f, 0.4f), .specular = 0.04f, .roughness = 0.3f,
                        .double_sided = double_sided, .texture = -1};
    w->sun = (light){.type = LIGHT_DIRECTIONAL, .direction = v3(0, 1, 0), .radiance = v3(1, 1, 1)};
    w->s.materials = &w->mat;
    w->s.material_count = 1;
    w->s.lights = &w->sun;
    w->s.light_count = 1;
    w->s.background = v3(0, 0, 0);
    w->s.width = w->s.height = 16;
    w->s.effects = 0;
    vec3 lo = v3(INFINITY, INFINITY, INFINITY), hi = v3(-INFINITY, -INFINITY, -INFINITY);
    for (size_t i = 0; i < w->s.mesh.vertex_count; i++) {
        lo = v3_min(lo, mesh_position(&w->s.mesh, (uint32_t)i));
        hi = v3_max(hi, mesh_position(&w->s.mesh, (uint32_t)i));
    }
    w->s.bounds_lo = lo;
    w->s.bounds_hi = hi;
    vx_err e;
    if (rt_build(&w->rt, &w->s, &e) || grid_build(&w->g, &w->s.mesh, n, &e)) {
        printf("not ok world: %s\n", e.msg);
        unit_failures++;
        return -1;
    }
    return 0;
}

static void world_free(world *w)
{
    grid_free(&w->g);
    rt_free(&w->rt);
    mesh_free(&w->s.mesh);
    free(w);
}

static world *world_new(void) { return calloc(1, sizeof(world)); }

/* The cell's box in double, from the documented mapping (grid.h), and its dense index. */
static void cell_box(const voxel_grid *g, int x, int y, int z, double lo[3], double *size)
{
    int c[3] = {x, y, z};
    for (int k = 0; k < 3; k++)
        lo[k] = g->origin_d[k] + c[k] * g->voxel_size_d;
    *size = g->voxel_size_d;
}

/* Slab test in double. */
static int slab2(const double p[3], const double d[3], const double lo[3], const double hi[3], double *t0,
                 double *t1, int *entry_axis, int *exit_axis)
{
    double a = -INFINITY, b = INFINITY;
    int ax = -1, bx = -1;
    for (int k = 0; k < 3; k++) {
        if (d[k] == 0.0) {
            if (p[k] < lo[k] || p[k] > hi[k])
                return 0;
            continue;
        }
        double u = (lo[k] - p[k]) / d[k], v = (hi[k] - p[k]) / d[k];
        if (u > v) {
            double t = u;
            u = v;
            v = t;
        }
        if (u > a) {
            a = u;
            ax = k;
        }
        if (v < b) {
            b = v;
            bx = k;
        }
    }
    *t0 = a;
    *t1 = b;
    if (entry_axis)
        *entry_axis = ax;
    if (exit_axis)
        *exit_axis = bx;
    return a <= b;
}

static int slab(const double p[3], const double d[3], const double lo[3], const double hi[3], double *t0,
                double *t1, int *entry_axis)
{
    return slab2(p, d, lo, hi, t0, t1, entry_axis, NULL);
}

/* ---------- generation ---------- */

/* E[1 / (|x|+|y|+|z|)] over the unit sphere by midpoint quadrature in (cos theta, phi). */
static double mean_inverse_l1(void)
{
    const int NZ = 2000, NP = 4000;
    double sum = 0;
    for (int i = 0; i < NZ; i++) {
        double z = -1.0 + (i + 0.5) * 2.0 / NZ, r = sqrt(1.0 - z * z);
        for (int j = 0; j < NP; j++) {
            double ph = (j + 0.5) * 2.0 * M_PI / NP;
            sum += 1.0 / (fabs(r * cos(ph)) + fabs(r * sin(ph)) + fabs(z));
        }
    }
    return sum / ((double)NZ * NP);
}

static void test_generation(void)
{
    world *w = world_new();
    /* A 2 x 2 quad in z = 0 (front +z); at N = 8 the voxel size is 2 / 5 and the quad's plane runs
     * through the centres of layer z = 1 (grid.h). */
    mesh_add_quad(&w->s.mesh, v3(-1, -1, 0), v3(1, -1, 0), v3(1, 1, 0), v3(-1, 1, 0), 0);
    if (world_build(w, 8, 0)) {
        world_free(w);
        return;
    }
    const voxel_grid *g = &w->g;
    int64_t idx = grid_index(g, 0, 3, 3, 1);
    CHECK("generation: the quad's voxel (3,3,1) is non-empty", idx >= 0);
    if (idx < 0) {
        world_free(w);
        return;
    }
    double lo[3], size, hi[3];
    cell_box(g, 3, 3, 1, lo, &size);
    for (int k = 0; k < 3; k++)
        hi[k] = lo[k] + size;

    enum { K = 200000 };
    vx_sample *s = malloc(sizeof *s * K);
    bake_generate_rays(&w->rt, g, (size_t)idx, 7, K, s);

    /* Directions: unit, mean 0, second moment I/3. Standard errors: mean sqrt(1/(3K)); diagonal
     * sqrt((1/5 - 1/9)/K); off-diagonal sqrt(1/(15K)). */
    double mean[3] = {0}, mom[3][3] = {{0}}, worst_len = 0;
    for (int i = 0; i < K; i++) {
        double d[3] = {s[i].dir.x, s[i].dir.y, s[i].dir.z};
        worst_len = fmax(worst_len, fabs(sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - 1.0));
        for (int a = 0; a < 3; a++) {
            mean[a] += d[a] / K;
            for (int b = 0; b < 3; b++)
                mom[a][b] += d[a] * d[b] / K;
        }
    }
    CHECK("generation: directions are unit vectors", worst_len < 1e-5);
    double se_mean = sqrt(1.0 / (3.0 * K)), se_diag = sqrt((0.2 - 1.0 / 9.0) / K), se_off = sqrt(1.0 / (15.0 * K));
    const char *axes = "xyz";
    for (int a = 0; a < 3; a++) {
        char name[96];
        snprintf(name, sizeof name, "generation: mean direction %c = 0", axes[a]);
        CHECK_NEAR(name, mean[a], 0.0, 5 * se_mean);
        for (int b = a; b < 3; b++) {
            snprintf(name, sizeof name, "generation: E[d%c d%c] = %s", axes[a], axes[b], a == b ? "1/3" : "0");
            CHECK_NEAR(name, mom[a][b], a == b ? 1.0 / 3.0 : 0.0, 5 * (a == b ? se_diag : se_off));
        }
    }

    /* Origins outside the scene's bounding sphere; [t_entry, t_exit] = the slab interval; the line
     * really crosses the voxel there. */
    double sc[3], R = 0;
    for (int k = 0; k < 3; k++) {
        sc[k] = 0.5 * ((double)v3_get(w->s.bounds_lo, k) + v3_get(w->s.bounds_hi, k));
        double e = v3_get(w->s.bounds_hi, k) - v3_get(w->s.bounds_lo, k);
        R += 0.25 * e * e;
    }
    R = sqrt(R);
    int outside = 1, ordered = 1, interval = 1, crosses = 1;
    double worst_interval = 0;
    int face_count[3] = {0};
    double fsum[2] = {0}, fsq[2] = {0}, fcross = 0, chord_sum = 0, chord_sq = 0;
    int bins[4][4] = {{0}};
    int nface = 0;
    for (int i = 0; i < K; i++) {
        double o[3] = {s[i].origin.x, s[i].origin.y, s[i].origin.z}, d[3] = {s[i].dir.x, s[i].dir.y, s[i].dir.z};
        double r2 = 0;
        for (int k = 0; k < 3; k++)
            r2 += (o[k] - sc[k]) * (o[k] - sc[k]);
        outside &= sqrt(r2) > R;
        /* float t near 3 resolves ~2.4e-7: a line through an edge may get t_entry == t_exit. */
        ordered &= s[i].t_entry <= s[i].t_exit;
        double t0, t1;
        int ax, bx;
        if (!slab2(o, d, lo, hi, &t0, &t1, &ax, &bx) || t1 - t0 <= 0) {
            /* The origin was rounded to float far from the voxel, so a line through an edge or a
             * corner may miss it by ~1e-7: that must still be a near miss, and such a line has no
             * entry face to count. */
            double glo[3], ghi[3], g0, g1;
            for (int k = 0; k < 3; k++)
                glo[k] = lo[k] - 1e-5 * size, ghi[k] = hi[k] + 1e-5 * size;
            if (!slab(o, d, glo, ghi, &g0, &g1, NULL)) {
                interval = 0;
                printf("# sample %d: the line misses the voxel\n", i);
            }
            continue;
        }
        ordered &= t1 - t0 < 1e-6 * t1 || s[i].t_entry < s[i].t_exit;
        /* The origin and t are floats: positions are good to ~1e-7 of |origin| + t, and a crossing
         * of the plane of axis k moves by that over |d_k| (grazing lines cross slowly). */
        double omax = fmax(fabs(o[0]), fmax(fabs(o[1]), fabs(o[2])));
        double pos_err = 1e-6 * (omax + fabs(t1));
        double err0 = fabs(t0 - s[i].t_entry) / (pos_err / fmax(fabs(d[ax]), 1e-6));
        double err1 = fabs(t1 - s[i].t_exit) / (pos_err / fmax(fabs(d[bx]), 1e-6));
        worst_interval = fmax(worst_interval, fmax(err0, err1));
        interval &= err0 <= 1 && err1 <= 1;
        double tm = 0.5 * ((double)s[i].t_entry + s[i].t_exit);
        for (int k = 0; k < 3; k++) {
            double p = o[k] + tm * d[k];
            crosses &= p >= lo[k] - 1e-6 && p <= hi[k] + 1e-6;
        }
        chord_sum += (t1 - t0) / size;
        chord_sq += (t1 - t0) * (t1 - t0) / (size * size);
        /* The entry point on face axis `ax`, in face coordinates u, v in [0, 1]. */
        face_count[ax]++;
        double uv[2];
        for (int j = 0, m = 0; j < 3; j++)
            if (j != ax)
                uv[m++] = (o[j] + t0 * d[j] - lo[j]) / size;
        for (int m = 0; m < 2; m++) {
            fsum[m] += uv[m];
            fsq[m] += (uv[m] - 0.5) * (uv[m] - 0.5);
        }
        fcross += (uv[0] - 0.5) * (uv[1] - 0.5);
        int bu = (int)fmin(3, fmax(0, floor(uv[0] * 4))), bv = (int)fmin(3, fmax(0, floor(uv[1] * 4)));
        bins[bu][bv]++;
        nface++;
    }
    CHECK("generation: origins outside the scene's bounding sphere", outside);
    CHECK("generation: t_entry < t_exit (<= where the chord is below float resolution)", ordered);
    if (!interval)
        printf("# worst |t - slab| = %g x tolerance\n", worst_interval);
    CHECK("generation: [t_entry, t_exit] = the line's slab interval through the voxel", interval);
    CHECK("generation: the midpoint of [t_entry, t_exit] lies in the voxel", crosses);
    /* Each pair of faces takes E[|w_k| / (|w_x|+|w_y|+|w_z|)] = 1/3 of the lines. */
    for (int k = 0; k < 3; k++) {
        char name[96];
        snprintf(name, sizeof name, "generation: 1/3 of the lines enter through the %c faces", axes[k]);
        CHECK_NEAR(name, (double)face_count[k] / nface, 1.0 / 3.0, 5 * sqrt(2.0 / 9.0 / nface));
    }
    /* Entry points uniform on the face: mean 1/2, variance 1/12 (SE sqrt((1/80 - 1/144)/n)),
     * covariance 0 (SE sqrt(1/144/n)), and a 4 x 4 chi-square (15 degrees of freedom: 45 is p ~ 1e-4). */
    CHECK_NEAR("generation: entry points on faces: mean u = 1/2", fsum[0] / nface, 0.5, 5 * sqrt(1.0 / 12 / nface));
    CHECK_NEAR("generation: entry points on faces: mean v = 1/2", fsum[1] / nface, 0.5, 5 * sqrt(1.0 / 12 / nface));
    double se_var = sqrt((1.0 / 80 - 1.0 / 144) / nface);
    CHECK_NEAR("generation: entry points on faces: var u = 1/12", fsq[0] / nface, 1.0 / 12, 5 * se_var);
    CHECK_NEAR("generation: entry points on faces: var v = 1/12", fsq[1] / nface, 1.0 / 12, 5 * se_var);
    CHECK_NEAR("generation: entry points on faces: cov(u, v) = 0", fcross / nface, 0.0, 5 * sqrt(1.0 / 144 / nface));
    double chi2 = 0, expect = nface / 16.0;
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++)
            chi2 += (bins[a][b] - expect) * (bins[a][b] - expect) / expect;
    printf("# entry-point chi-square (15 dof) = %.1f\n", chi2);
    CHECK("generation: entry points uniform on the faces (chi-square < 45)", chi2 < 45);
    /* Mean chord = size x E[1 / |w|_1] (lines uniform over the projection, directions uniform). */
    double chord = chord_sum / nface, chord_sd = sqrt(fmax(0, chord_sq / nface - chord * chord));
    double want_chord = mean_inverse_l1();
    printf("# mean chord / size = %.5f, expected %.5f\n", chord, want_chord);
    CHECK_NEAR("generation: mean chord = size x E[1/(|wx|+|wy|+|wz|)]", chord, want_chord, 5 * chord_sd / sqrt(nface));
    /* Isotropic uniform random lines (directions weighted by projected area) would give Cauchy's
     * 4V/S = 2/3 instead: the tolerance above must exclude that, or the check cannot tell. */
    CHECK("generation: the chord check separates uniform directions from area-weighted ones (Cauchy 2/3)",
          5 * chord_sd / sqrt(nface) < fabs(want_chord - 2.0 / 3.0));

    /* Streams: the same (seed, voxel) repeats exactly; another seed or voxel differs. */
    enum { KS = 256 };
    vx_sample *a = malloc(sizeof *a * KS), *b = malloc(sizeof *b * KS);
    bake_generate_rays(&w->rt, g, (size_t)idx, 7, KS, a);
    bake_generate_rays(&w->rt, g, (size_t)idx, 7, KS, b);
    CHECK("streams: the same seed gives identical rays", memcmp(a, b, sizeof *a * KS) == 0);
    bake_trace(&w->rt, g, (size_t)idx, a, KS);
    bake_trace(&w->rt, g, (size_t)idx, b, KS);
    CHECK("streams: the same seed gives identical classified samples", memcmp(a, b, sizeof *a * KS) == 0);
    bake_generate_rays(&w->rt, g, (size_t)idx, 8, KS, b);
    int same = 0;
    for (int i = 0; i < KS; i++)
        same += a[i].dir.x == b[i].dir.x && a[i].dir.y == b[i].dir.y;
    CHECK("streams: another seed gives other rays", same == 0);
    int64_t other = grid_index(g, 0, 4, 3, 1);
    if (other >= 0) {
        bake_generate_rays(&w->rt, g, (size_t)other, 7, KS, b);
        same = 0;
        for (int i = 0; i < KS; i++)
            same += a[i].dir.x == b[i].dir.x && a[i].dir.y == b[i].dir.y;
        CHECK("streams: another voxel gets other rays", same == 0);
    }
    free(a);
    free(b);
    free(s);
    world_free(w);
}

/* ---------- classification against a Monte Carlo reference ---------- */

enum { C_MISS = 0, C_FRONT = 1, C_BACK = 2, C_OUTSIDE = 3 };
static const char *const class_names[4] = {"MISS", "INSIDE_FRONT", "INSIDE_BACK", "OUTSIDE"};

/* The reference's geometry: the mesh itself (the reference intersects its triangles by plane
 * crossing and edge functions, not the sampler's Moller-Trumbore), plus for the winding check a
 * parallelogram c + a u + b w (front = u x w side) or a box. */
typedef struct {
    int is_box;
    double c[3], u[3], w[3]; /* quad */
    int double_sided;
    const mesh *m;
    int own[64], own_count; /* the voxel's own triangles (filled by ref_frequencies) */
} ref_geometry;

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static void tri_vertices(const mesh *m, int t, double v[3][3])
{
    for (int k = 0; k < 3; k++) {
        vec3 q = mesh_position(m, m->indices[3 * (size_t)t + (size_t)k]);
        v[k][0] = q.x, v[k][1] = q.y, v[k][2] = q.z;
    }
}

/* Brito et al. 2023 §3.2 by brute force: the line p + s d (its piece inside the voxel is
 * s in [0, s_exit]) against the voxel's own triangles over its whole length; the closest crossing
 * inside the voxel is case (a) (front/back by the winding), outside it case (b), none case (c). */
static int ref_classify(const ref_geometry *rg, const double p[3], const double d[3], double s_exit)
{
    double best = INFINITY;
    int front = 0;
    for (int i = 0; i < rg->own_count; i++) {
        double v[3][3], e1[3], e2[3], n[3];
        tri_vertices(rg->m, rg->own[i], v);
        for (int k = 0; k < 3; k++)
            e1[k] = v[1][k] - v[0][k], e2[k] = v[2][k] - v[0][k];
        cross3(e1, e2, n);
        double dn = dot3(d, n);
        if (dn == 0)
            continue;
        double pa[3] = {v[0][0] - p[0], v[0][1] - p[1], v[0][2] - p[2]};
        double sh = dot3(pa, n) / dn, q[3];
        for (int k = 0; k < 3; k++)
            q[k] = p[k] + sh * d[k];
        int in = 1;
        for (int k = 0; k < 3 && in; k++) { /* q on the inner side of every edge */
            const double *a = v[k], *b = v[(k + 1) % 3];
            double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, aq[3] = {q[0] - a[0], q[1] - a[1], q[2] - a[2]}, c[3];
            cross3(ab, aq, c);
            in = dot3(c, n) >= 0;
        }
        if (in && sh < best) {
            best = sh;
            front = dn < 0;
        }
    }
    if (!isfinite(best))
        return C_MISS;
    if (best >= 0 && best <= s_exit)
        return front || rg->double_sided ? C_FRONT : C_BACK;
    return C_OUTSIDE;
}

/* Reference class frequencies over lines through the voxel box [lo, lo + size]. area_weighted = 0:
 * directions uniform on the sphere (the sampler's documented measure); 1: directions weighted by
 * the voxel's projected area (isotropic uniform random lines). Either way the line's entry point is
 * drawn as: a visible face with probability |w_k| / |w|_1, then uniform on that face. */
static void ref_frequencies(const ref_geometry *rg_in, const double lo[3], double size, int area_weighted, long M,
                            uint64_t seed, double freq[4])
{
    ref_geometry own = *rg_in, *rg = &own;
    own.own_count = 0;
    double hi[3] = {lo[0] + size, lo[1] + size, lo[2] + size};
    for (int t = 0; t < (int)rg->m->triangle_count && own.own_count < 64; t++) {
        double v[3][3];
        tri_vertices(rg->m, t, v);
        if (tribox_overlap_d(lo, hi, v[0], v[1], v[2]))
            own.own[own.own_count++] = t;
    }
    uint64_t r = seed;
    long count[4] = {0};
    for (long i = 0; i < M; i++) {
        double d[3];
        rnd_dir(&r, d);
        double l1 = fabs(d[0]) + fabs(d[1]) + fabs(d[2]);
        if (area_weighted && rnd01(&r) * sqrt(3.0) > l1) {
            i--;
            continue;
        }
        double pick = rnd01(&r) * l1;
        int k = pick < fabs(d[0]) ? 0 : (pick < fabs(d[0]) + fabs(d[1]) ? 1 : 2);
        double p[3];
        for (int j = 0; j < 3; j++)
            p[j] = lo[j] + size * rnd01(&r);
        p[k] = d[k] > 0 ? lo[k] : lo[k] + size; /* the face the line enters through */
        /* Exit: the nearest plane crossing ahead among the far faces. */
        double s_exit = INFINITY;
        for (int j = 0; j < 3; j++)
            if (d[j] != 0)
                s_exit = fmin(s_exit, ((d[j] > 0 ? lo[j] + size : lo[j]) - p[j]) / d[j]);
        count[ref_classify(rg, p, d, s_exit)]++;
    }
    for (int c = 0; c < 4; c++)
        freq[c] = (double)count[c] / (double)M;
}

/* The sampler's class frequencies for one voxel. */
static void sampler_frequencies(world *w, int64_t idx, int K, double freq[4], int *winding_ok, int *normal_ok,
                                const ref_geometry *rg)
{
    vx_sample *s = malloc(sizeof *s * (size_t)K);
    bake_generate_rays(&w->rt, &w->g, (size_t)idx, 11, K, s);
    bake_trace(&w->rt, &w->g, (size_t)idx, s, K);
    long count[4] = {0};
    *winding_ok = *normal_ok = 1;
    for (int i = 0; i < K; i++) {
        count[s[i].kind]++;
        if (s[i].kind != VX_SAMPLE_INSIDE_FRONT && s[i].kind != VX_SAMPLE_INSIDE_BACK)
            continue;
        /* The normal faces the incoming ray; front hits carry the material's colour, back hits none. */
        float dn = v3_dot(s[i].normal, s[i].dir);
        *normal_ok &= dn <= 1e-6f && fabsf(v3_length(s[i].normal) - 1.0f) < 1e-4f;
        /* (the colour is the material's times interpolated white vertex colours: 1 up to rounding) */
        if (s[i].kind == VX_SAMPLE_INSIDE_FRONT)
            *normal_ok &= v3_length(v3_sub(s[i].albedo, w->mat.color)) < 1e-6f;
        else
            *normal_ok &= s[i].albedo.x == 0 && s[i].albedo.y == 0 && s[i].albedo.z == 0;
        /* Winding, for a quad: front iff the ray travels against u x w (unless double-sided). */
        if (!rg->is_box) {
            double n[3] = {rg->u[1] * rg->w[2] - rg->u[2] * rg->w[1], rg->u[2] * rg->w[0] - rg->u[0] * rg->w[2],
                           rg->u[0] * rg->w[1] - rg->u[1] * rg->w[0]};
            double d[3] = {s[i].dir.x, s[i].dir.y, s[i].dir.z};
            double c = dot3(d, n) / sqrt(dot3(n, n));
            if (fabs(c) > 1e-4) {
                int want = rg->double_sided || c < 0 ? VX_SAMPLE_INSIDE_FRONT : VX_SAMPLE_INSIDE_BACK;
                *winding_ok &= s[i].kind == want;
            }
        }
    }
    for (int c = 0; c < 4; c++)
        freq[c] = (double)count[c] / K;
    free(s);
}

/* Compares the sampler with the reference for one voxel: every class within 5 combined standard
 * errors. */
static void compare_classes(const char *what, world *w, int cx, int cy, int cz, const ref_geometry *rg, int K, long M)
{
    char name[256];
    int64_t idx = grid_index(&w->g, 0, cx, cy, cz);
    snprintf(name, sizeof name, "%s: voxel (%d,%d,%d) is non-empty", what, cx, cy, cz);
    CHECK(name, idx >= 0);
    if (idx < 0)
        return;
    double lo[3], size;
    cell_box(&w->g, cx, cy, cz, lo, &size);
    double got[4], want[4];
    int winding_ok, normal_ok;
    sampler_frequencies(w, idx, K, got, &winding_ok, &normal_ok, rg);
    ref_frequencies(rg, lo, size, 0, M, 0x1234567ULL + (uint64_t)cx * 31 + (uint64_t)cz, want);
    for (int c = 0; c < 4; c++) {
        double se = sqrt(want[c] * (1 - want[c]) / K + want[c] * (1 - want[c]) / M);
        snprintf(name, sizeof name, "%s: %s fraction (sampler %.4f, reference %.4f)", what, class_names[c], got[c],
                 want[c]);
        CHECK_NEAR(name, got[c], want[c], 5 * se + 1e-9);
    }
    snprintf(name, sizeof name, "%s: normals face the ray; front hits coloured, back hits black", what);
    CHECK(name, normal_ok);
    if (!rg->is_box) {
        snprintf(name, sizeof name, "%s: front/back follows the winding", what);
        CHECK(name, winding_ok);
    }
}

static void test_axis_quad(int reversed, int double_sided)
{
    world *w = world_new();
    /* Counter-clockwise seen from +z: front = +z; reversed winding: front = -z. */
    if (reversed)
        mesh_add_quad(&w->s.mesh, v3(-1, -1, 0), v3(-1, 1, 0), v3(1, 1, 0), v3(1, -1, 0), 0);
    else
        mesh_add_quad(&w->s.mesh, v3(-1, -1, 0), v3(1, -1, 0), v3(1, 1, 0), v3(-1, 1, 0), 0);
    if (world_build(w, 8, double_sided)) {
        world_free(w);
        return;
    }
    ref_geometry rg = {.is_box = 0, .c = {0, 0, 0}, .u = {1, 0, 0}, .w = {0, reversed ? -1 : 1, 0}, .m = &w->s.mesh,
                       .double_sided = double_sided};
    char what[96];
    snprintf(what, sizeof what, "quad z=0%s%s", reversed ? " (reversed winding)" : "",
             double_sided ? " (double-sided)" : "");
    compare_classes(what, w, 3, 3, 1, &rg, 60000, 1000000);
    if (!reversed && !double_sided) {
        /* A plane through the whole voxel: INSIDE = 1/3 exactly, under either line measure
         * (E|w_z| / |w|_1 = 1/3 by symmetry; Crofton: 2 a^2 / 6 a^2). */
        int64_t idx = grid_index(&w->g, 0, 3, 3, 1);
        double got[4];
        int a, b;
        sampler_frequencies(w, idx, 60000, got, &a, &b, &rg);
        CHECK_NEAR("quad z=0: INSIDE fraction = 1/3 (analytic)", got[C_FRONT] + got[C_BACK], 1.0 / 3.0,
                   5 * sqrt(2.0 / 9.0 / 60000));
        CHECK_NEAR("quad z=0: half the INSIDE hits are front hits", got[C_FRONT], got[C_BACK],
                   5 * sqrt(2 * (1.0 / 6.0) / 60000));
    }
    world_free(w);
}

/* A tilted plane through a voxel (no symmetry to lean on: only the Monte Carlo reference knows the
 * fractions). */
static void test_tilted_quad(void)
{
    world *w = world_new();
    const double su = 1.5 / sqrt(2.0), sw = 1.5 / sqrt(6.0);
    double u[3] = {su, -su, 0}, wv[3] = {sw, sw, -2 * sw}, c[3] = {0.05, -0.02, 0.01};
    vec3 P[4];
    const int sg[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int i = 0; i < 4; i++)
        P[i] = v3((float)(c[0] + sg[i][0] * u[0] + sg[i][1] * wv[0]), (float)(c[1] + sg[i][0] * u[1] + sg[i][1] * wv[1]),
                  (float)(c[2] + sg[i][0] * u[2] + sg[i][1] * wv[2]));
    mesh_add_quad(&w->s.mesh, P[0], P[1], P[2], P[3], 0);
    if (world_build(w, 12, 0)) {
        world_free(w);
        return;
    }
    ref_geometry rg = {.is_box = 0, .c = {c[0], c[1], c[2]}, .u = {u[0], u[1], u[2]}, .w = {wv[0], wv[1], wv[2]}, .m = &w->s.mesh};
    /* The non-empty voxel whose centre lies closest to the plane (the plane then cuts it roughly in
     * half, and it is far from the quad's edges). */
    double nrm[3] = {u[1] * wv[2] - u[2] * wv[1], u[2] * wv[0] - u[0] * wv[2], u[0] * wv[1] - u[1] * wv[0]};
    double nlen = sqrt(dot3(nrm, nrm)), best = INFINITY;
    int cx = 0, cy = 0, cz = 0;
    for (size_t i = 0; i < grid_count(&w->g, 0); i++) {
        int x, y, z;
        grid_coords(&w->g, 0, i, &x, &y, &z);
        double lo[3], size, q[3];
        cell_box(&w->g, x, y, z, lo, &size);
        for (int k = 0; k < 3; k++)
            q[k] = lo[k] + 0.5 * size - c[k];
        double dist = fabs(dot3(q, nrm)) / nlen + 1e-3 * sqrt(dot3(q, q)); /* ties: nearest the centre */
        if (dist < best) {
            best = dist;
            cx = x, cy = y, cz = z;
        }
    }
    compare_classes("tilted quad", w, cx, cy, cz, &rg, 60000, 1000000);
    double lo[3], size, uni[4], iur[4];
    cell_box(&w->g, cx, cy, cz, lo, &size);
    ref_frequencies(&rg, lo, size, 0, 300000, 99, uni);
    ref_frequencies(&rg, lo, size, 1, 300000, 98, iur);
    /* For information: this plane barely separates the two line measures (the chord check does). */
    printf("# tilted quad INSIDE fraction: uniform directions %.4f, area-weighted directions %.4f\n",
           uni[C_FRONT] + uni[C_BACK], iur[C_FRONT] + iur[C_BACK]);
    world_free(w);
}

/* Other geometry between the scene's boundary and the voxel must not shadow its classes (the paper
 * intersects the voxel's own list only): the quad z = 0 with a second quad above it that does not
 * touch voxel (3,3,1). */
static void test_occluded_quad(void)
{
    world *w = world_new();
    mesh_add_quad(&w->s.mesh, v3(-1, -1, 0), v3(1, -1, 0), v3(1, 1, 0), v3(-1, 1, 0), 0);
    mesh_add_quad(&w->s.mesh, v3(-1, -1, 0.9f), v3(1, -1, 0.9f), v3(1, 1, 0.9f), v3(-1, 1, 0.9f), 0);
    if (world_build(w, 8, 0)) {
        world_free(w);
        return;
    }
    ref_geometry rg = {.is_box = 0, .c = {0, 0, 0}, .u = {1, 0, 0}, .w = {0, 1, 0}, .m = &w->s.mesh};
    compare_classes("quad z=0 under an occluder", w, 3, 3, 1, &rg, 60000, 1000000);
    world_free(w);
}

static void test_box(void)
{
    world *w = world_new();
    mesh_add_box(&w->s.mesh, v3(-1, -1, -1), v3(1, 1, 1), 0);
    if (world_build(w, 8, 0)) {
        world_free(w);
        return;
    }
    ref_geometry rg = {.is_box = 1, .m = &w->s.mesh};
    /* Voxel (3,3,1) is cut through its centre by the -z face; (3,3,6) by the +z face (N = 8: both
     * faces lie on cell centres, grid.h); (1,3,3) by the -x face. */
    compare_classes("box -z face", w, 3, 3, 1, &rg, 60000, 1000000);
    compare_classes("box +z face", w, 3, 3, 6, &rg, 60000, 1000000);
    compare_classes("box -x face", w, 1, 3, 3, &rg, 60000, 1000000);
    /* (1,3,1) holds the edge where the -x and -z faces meet: lines cross one face before entering
     * the voxel, the paper's case (b) before the entry. */
    compare_classes("box -x/-z edge", w, 1, 3, 1, &rg, 60000, 1000000);
    world_free(w);
}

/* A quad lying exactly on the plane between two layers of cells: grid.h's closed cells make both
 * layers non-empty, and the sampler must find the quad INSIDE both (1/3 of the lines through a cube
 * cross a given face). Exact numbers: extent 2 at N = 11 gives voxel size 2 / 8 = 0.25; a small
 * triangle at z = 0 sets the bounds' minimum, so the z origin is -0.375 and z = 0.125 is the
 * boundary between layers 1 and 2. */
static void test_quad_on_face(void)
{
    world *w = world_new();
    mesh_add_quad(&w->s.mesh, v3(-1, -1, 0.125f), v3(1, -1, 0.125f), v3(1, 1, 0.125f), v3(-1, 1, 0.125f), 0);
    mesh_add_flat_triangle(&w->s.mesh, v3(-1, -1, 0), v3(-0.9f, -1, 0), v3(-1, -0.9f, 0), 0);
    if (world_build(w, 11, 0)) {
        world_free(w);
        return;
    }
    CHECK_NEAR("on face: voxel size 0.25", w->g.voxel_size_d, 0.25, 0);
    CHECK_NEAR("on face: z = 0.125 is a cell boundary", w->g.origin_d[2] + 2 * w->g.voxel_size_d, 0.125, 0);
    CHECK("on face: the grid marks both cells around the face (grid.h: closed cells)",
          grid_index(&w->g, 0, 5, 5, 1) >= 0 && grid_index(&w->g, 0, 5, 5, 2) >= 0 &&
              grid_index(&w->g, 0, 5, 5, 0) < 0 && grid_index(&w->g, 0, 5, 5, 3) < 0);
    ref_geometry rg = {.is_box = 0, .c = {0, 0, 0.125}, .u = {1, 0, 0}, .w = {0, 1, 0}, .m = &w->s.mesh};
    for (int layer = 1; layer <= 2; layer++) {
        int64_t idx = grid_index(&w->g, 0, 5, 5, layer);
        if (idx < 0)
            continue;
        double got[4];
        int winding_ok, normal_ok;
        sampler_frequencies(w, idx, 60000, got, &winding_ok, &normal_ok, &rg);
        char name[128];
        snprintf(name, sizeof name, "on face: INSIDE fraction = 1/3 in the cell %s the quad (got %.4f)",
                 layer == 1 ? "below" : "above", got[C_FRONT] + got[C_BACK]);
        CHECK_NEAR(name, got[C_FRONT] + got[C_BACK], 1.0 / 3.0, 5 * sqrt(2.0 / 9.0 / 60000));
        snprintf(name, sizeof name, "on face: front/back follows the winding in the cell %s", layer == 1 ? "below" : "above");
        CHECK(name, winding_ok && normal_ok);
    }
    world_free(w);
}

int main(void)
{
    test_generation();
    test_axis_quad(0, 0);
    test_axis_quad(1, 0);
    test_axis_quad(0, 1);
    test_tilted_quad();
    test_box();
    test_occluded_quad();
    test_quad_on_face();
    return unit_exit();
}
