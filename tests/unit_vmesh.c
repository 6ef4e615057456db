/* The `vmesh` model (Brito et al. 2023): SGGX fit, disk-disk overlap, directional opacity, faces and
 * shading, each against an expectation computed independently of the code under test:
 *  - SGGX: normals drawn from known distributions whose second moments and mean |v . n| are known in
 *    closed form (a direction, a plane's two sides, a spherical cap, a great circle, the sphere);
 *  - overlap: numeric integration on a fine grid;
 *  - subgrid traversal: brute-force stepping along random chords;
 *  - opacity and shading: records baked from synthetic sample rays that follow the shared sampler's
 *    recipe (direction uniform on the sphere, origin uniform over the voxel's projection) and are
 *    classified against analytic planes here, not by Embree; the expectations are the planes'
 *    projected areas and Lambert (plus Beckmann) of the planes' own normals;
 *  - one end-to-end case through the real sampler (tracer/bake/bake.h) on a one-quad scene.
 * Lines starting with '#' report the curves the checks look at. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "grid.h"
#include "rng.h"
#include "rt.h"
#include "scene.h"
#include "unit.h"
#include "vmesh_bake.h"
#include "vmesh_opacity.h"
#include "vmesh_shade.h"

#define PI 3.14159265358979323846

extern const vx_model model_vmesh;

/* ---------- random normals ---------- */

static vec3 random_sphere(rng *r)
{
    float z = 1.0f - 2.0f * rng_float(r), phi = 2.0f * (float)PI * rng_float(r);
    float s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    return v3(s * cosf(phi), s * sinf(phi), z);
}

/* Uniform on the spherical cap of half-angle a around +z: cos(theta) uniform in [cos a, 1]. */
static vec3 random_cap(rng *r, float a)
{
    float z = 1.0f - (1.0f - cosf(a)) * rng_float(r), phi = 2.0f * (float)PI * rng_float(r);
    float s = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    return v3(s * cosf(phi), s * sinf(phi), z);
}

static int frame_ok(const sggx_frame *f)
{
    for (int i = 0; i < 3; i++) {
        if (fabsf(v3_length(f->axis[i]) - 1.0f) > 1e-4f || !isfinite(f->area[i]) || f->area[i] < 0.0999f ||
            f->area[i] > 1.0001f)
            return 0;
        for (int j = i + 1; j < 3; j++)
            if (fabsf(v3_dot(f->axis[i], f->axis[j])) > 1e-4f)
                return 0;
    }
    return v3_dot(v3_cross(f->axis[0], f->axis[1]), f->axis[2]) > 0.9999f; /* right-handed */
}

static void test_sggx(void)
{
    enum { N = 20000 };
    static vec3 nrm[N];
    sggx_frame f;
    char name[128];
    rng r = rng_seed(11, 0);

    /* One direction, 50 times: the eigenvector is the direction; areas 1 and the 0.1 clamp. */
    vec3 d = v3_normalize(v3(1, 2, 3));
    for (int i = 0; i < 50; i++)
        nrm[i] = d;
    sggx_fit(nrm, 50, VMESH_MIN_AREA, &f);
    CHECK("sggx single direction: orthonormal right-handed frame", frame_ok(&f));
    CHECK_NEAR("sggx single direction: axis 0 is the direction", fabs(v3_dot(f.axis[0], d)), 1.0, 1e-5);
    CHECK_NEAR("sggx single direction: projected area along it", f.area[0], 1.0, 1e-5);
    CHECK_NEAR("sggx single direction: area across (clamped)", f.area[1], 0.1, 1e-6);
    CHECK_NEAR("sggx single direction: area across 2 (clamped)", f.area[2], 0.1, 1e-6);

    /* A plane's two sides: same second moment and same mean |v.n| as one side. */
    for (int i = 0; i < 100; i++)
        nrm[i] = v3_scale(d, i % 2 ? -1.0f : 1.0f);
    sggx_fit(nrm, 100, VMESH_MIN_AREA, &f);
    CHECK("sggx two sides: frame", frame_ok(&f));
    CHECK_NEAR("sggx two sides: axis 0 along the plane normal", fabs(v3_dot(f.axis[0], d)), 1.0, 1e-5);
    CHECK_NEAR("sggx two sides: area along the normal", f.area[0], 1.0, 1e-5);
    CHECK_NEAR("sggx two sides: area across", f.area[1] + f.area[2], 0.2, 1e-5);

    /* Caps of half-angle a: E = diag(q, q, c), c = mean cos^2 = (1 + cos a + cos^2 a) / 3, q = (1 -
     * c) / 2, so axis 0 = z while c > q; mean |cos| = (1 + cos a) / 2 and mean |x| = (2 / pi) mean
     * sin theta = (2 / pi) (a - sin a cos a) / (2 (1 - cos a)). */
    const float caps[2] = {(float)(PI / 6), (float)(PI / 3)};
    for (int c = 0; c < 2; c++) {
        float a = caps[c];
        for (int i = 0; i < N; i++)
            nrm[i] = random_cap(&r, a);
        sggx_fit(nrm, N, VMESH_MIN_AREA, &f);
        double along = (1.0 + cos(a)) / 2.0;
        double across = fmax(0.1, (2.0 / PI) * (a - sin(a) * cos(a)) / (2.0 * (1.0 - cos(a))));
        snprintf(name, sizeof name, "sggx cap %.0f deg: frame", a * 180 / PI);
        CHECK(name, frame_ok(&f));
        snprintf(name, sizeof name, "sggx cap %.0f deg: axis 0 = cap axis", a * 180 / PI);
        CHECK_NEAR(name, fabs(f.axis[0].z), 1.0, 1e-3);
        snprintf(name, sizeof name, "sggx cap %.0f deg: projected area along the axis", a * 180 / PI);
        CHECK_NEAR(name, f.area[0], along, 0.01);
        snprintf(name, sizeof name, "sggx cap %.0f deg: projected areas across", a * 180 / PI);
        CHECK_NEAR(name, 0.5 * (f.area[1] + f.area[2]), across, 0.01);
    }

    /* A great circle in the xz-plane (a cylinder along y): E = diag(1/2, 0, 1/2), so the last axis is
     * y; areas 2/pi across y (mean |cos phi|) and the clamp along y. */
    for (int i = 0; i < N; i++) {
        float phi = 2.0f * (float)PI * rng_float(&r);
        nrm[i] = v3(cosf(phi), 0.0f, sinf(phi));
    }
    sggx_fit(nrm, N, VMESH_MIN_AREA, &f);
    CHECK("sggx great circle: frame", frame_ok(&f));
    CHECK_NEAR("sggx great circle: axis 2 = cylinder axis", fabs(f.axis[2].y), 1.0, 1e-3);
    CHECK_NEAR("sggx great circle: areas across the axis", 0.5 * (f.area[0] + f.area[1]), 2.0 / PI, 0.01);
    CHECK_NEAR("sggx great circle: area along the axis (clamped)", f.area[2], 0.1, 1e-6);

    /* The full sphere: mean |v.n| = 1/2 for every v, whatever frame the fit picks. */
    for (int i = 0; i < N; i++)
        nrm[i] = random_sphere(&r);
    sggx_fit(nrm, N, VMESH_MIN_AREA, &f);
    CHECK("sggx sphere: frame", frame_ok(&f));
    for (int k = 0; k < 3; k++) {
        snprintf(name, sizeof name, "sggx sphere: area %d = 1/2", k);
        CHECK_NEAR(name, f.area[k], 0.5, 0.01);
    }

    /* Degenerate sets: no normal, one normal. */
    sggx_fit(nrm, 0, VMESH_MIN_AREA, &f);
    CHECK("sggx no normals: identity frame", frame_ok(&f) && f.axis[0].x == 1.0f && f.axis[2].z == 1.0f);
    CHECK("sggx no normals: areas 1/2 (no preferred orientation)",
          f.area[0] == 0.5f && f.area[1] == 0.5f && f.area[2] == 0.5f);
    nrm[0] = v3(0, 0, -1);
    sggx_fit(nrm, 1, VMESH_MIN_AREA, &f);
    CHECK("sggx one normal: frame", frame_ok(&f));
    CHECK_NEAR("sggx one normal: axis 0", fabs(f.axis[0].z), 1.0, 1e-6);
    CHECK("sggx one normal: areas (1, 0.1, 0.1)",
          fabsf(f.area[0] - 1.0f) < 1e-6f && f.area[1] == 0.1f && f.area[2] == 0.1f);
}

/* ---------- disk-disk overlap ---------- */

static double overlap_numeric(double r1, double r2, double d)
{
    /* Midpoint rule over the smaller disk's bounding square, 3000^2 cells. */
    double rs = fmin(r1, r2), rl = fmax(r1, r2);
    int n = 3000;
    double h = 2.0 * rs / n, sum = 0.0;
    for (int i = 0; i < n; i++) {
        double x = -rs + (i + 0.5) * h;
        for (int j = 0; j < n; j++) {
            double y = -rs + (j + 0.5) * h;
            if (x * x + y * y <= rs * rs && (x - d) * (x - d) + y * y <= rl * rl)
                sum += 1.0;
        }
    }
    return sum * h * h;
}

/* vx_acosf (tracer/core/portable_acos.h, used by the disk overlap): within 2 ulp of double acos on a
 * fine sweep of [-1, 1], exact at the ends, and never decreasing the wrong way. */
static void test_portable_acos(void)
{
    double worst_ulp = 0.0;
    int monotone = 1;
    float prev = vx_acosf(-1.0f);
    for (int i = 0; i <= 2000000; i++) {
        float x = -1.0f + 2.0f * (float)i / 2000000.0f;
        double want = acos((double)x);
        float got = vx_acosf(x);
        double ulp = (double)nextafterf((float)want, INFINITY) - (double)(float)want;
        worst_ulp = fmax(worst_ulp, fabs((double)got - want) / ulp);
        monotone &= got <= prev;
        prev = got;
    }
    CHECK_NEAR("portable acos: within 2 ulp of acos on [-1, 1]", worst_ulp, 0.0, 2.0);
    CHECK("portable acos: non-increasing on [-1, 1]", monotone);
    CHECK("portable acos: acos(1) = 0, acos(-1) = pi, acos(0) = pi/2",
          vx_acosf(1.0f) == 0.0f && vx_acosf(-1.0f) == (float)PI && vx_acosf(0.0f) == (float)(PI / 2));
}

static void test_overlap(void)
{
    const struct {
        double r1, r2, d;
        const char *what;
    } cases[] = {
        {1.0, 1.0, 0.0, "equal radii, concentric"},
        {1.0, 1.0, 1e-4, "equal radii, almost concentric"},
        {1.0, 1.0, 1.0, "equal radii, half apart"},
        {1.0, 1.0, 1.9999, "equal radii, almost tangent"},
        {1.0, 0.5, 0.2, "containment"},
        {0.5, 1.0, 0.2, "containment (swapped)"},
        {1.0, 0.5, 0.5, "internal tangency"},
        {1.0, 0.5, 0.7, "lens"},
        {1.0, 0.5, 1.5, "external tangency"},
        {1.0, 0.5, 3.0, "no overlap"},
        {0.28867513, 0.125, 0.2, "sub-disk and axis-view cell disk"},
        {0.28867513, 0.2165, 0.4, "sub-disk and diagonal-view cell disk"},
    };
    char name[128];
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        double want = overlap_numeric(cases[i].r1, cases[i].r2, cases[i].d);
        double got = vmesh_disk_overlap((float)cases[i].r1, (float)cases[i].r2, (float)cases[i].d);
        double small = PI * fmin(cases[i].r1, cases[i].r2) * fmin(cases[i].r1, cases[i].r2);
        snprintf(name, sizeof name, "disk overlap %s (r %.3g, %.3g, d %.4g)", cases[i].what, cases[i].r1, cases[i].r2,
                 cases[i].d);
        CHECK_NEAR(name, got, want, 2e-3 * small + 1e-7);
    }
    CHECK("disk overlap: exactly 0 apart and exactly the small disk inside",
          vmesh_disk_overlap(1, 0.5f, 3) == 0.0f && vmesh_disk_overlap(1, 0.5f, 1.5f) == 0.0f &&
              vmesh_disk_overlap(1, 0.5f, 0.2f) == (float)PI * 0.25f);
    CHECK("disk overlap: zero or negative radius gives 0, negative distance as positive",
          vmesh_disk_overlap(0, 1, 0) == 0.0f && vmesh_disk_overlap(-1, 1, 0) == 0.0f &&
              vmesh_disk_overlap(1, 0.5f, -0.7f) == vmesh_disk_overlap(1, 0.5f, 0.7f));
    int mono = 1;
    float prev = vmesh_disk_overlap(0.3f, 0.2f, 0.0f);
    for (int i = 1; i <= 1000; i++) {
        float a = vmesh_disk_overlap(0.3f, 0.2f, 0.6f * (float)i / 1000.0f);
        mono &= a <= prev + 1e-7f && a >= 0.0f && isfinite(a);
        prev = a;
    }
    CHECK("disk overlap: non-negative, finite, non-increasing with distance", mono);
}

/* ---------- synthetic sample rays on the unit voxel [0,1]^3 ---------- */

/* A plane sheet n.x = offset (front side where n points), restricted to clip_n.x <= clip_d (clip_n
 * zero: unbounded). It belongs to the voxel's own triangles when it crosses the voxel. */
typedef struct {
    vec3 n;
    float offset;
    vec3 clip_n;
    float clip_d;
    vec3 albedo;
    int double_sided;
    float specular, roughness;
} sheet;

enum { SYN_PLANES = 0, SYN_FOAM = 1, SYN_EMPTY = 2 };

/* The shared sampler's recipe (tracer/bake/bake.c) re-implemented on the unit voxel: direction uniform on
 * the sphere, origin uniform over the voxel's projection (rejection in the bounding rectangle),
 * backed up 10 units. */
static void synth(int mode, const sheet *sh, int nsh, int n, uint64_t seed, vx_sample *out)
{
    rng r = rng_seed(seed, 1234);
    vec3 c = v3(0.5f, 0.5f, 0.5f);
    for (int i = 0; i < n; i++) {
        vec3 d = random_sphere(&r), t, b;
        v3_basis(d, &t, &b);
        float et = 0.5f * (fabsf(t.x) + fabsf(t.y) + fabsf(t.z)), eb = 0.5f * (fabsf(b.x) + fabsf(b.y) + fabsf(b.z));
        float s0 = 0, s1 = 0;
        vec3 p;
        for (;;) {
            p = v3_add(c, v3_add(v3_scale(t, (2 * rng_float(&r) - 1) * et), v3_scale(b, (2 * rng_float(&r) - 1) * eb)));
            float lo = -INFINITY, hi = INFINITY;
            for (int k = 0; k < 3; k++) {
                float pk = v3_get(p, k), dk = v3_get(d, k);
                if (fabsf(dk) < 1e-12f) {
                    if (pk < 0 || pk > 1)
                        lo = INFINITY;
                    continue;
                }
                float u = (0 - pk) / dk, v = (1 - pk) / dk;
                lo = fmaxf(lo, fminf(u, v));
                hi = fminf(hi, fmaxf(u, v));
            }
            if (lo < hi) {
                s0 = lo, s1 = hi;
                break;
            }
        }
        vx_sample *o = &out[i];
        memset(o, 0, sizeof *o);
        o->origin = v3_madd(p, d, -10.0f);
        o->dir = d;
        o->t_entry = 10.0f + s0;
        o->t_exit = 10.0f + s1;
        o->t_hit = INFINITY;
        o->kind = VX_SAMPLE_MISS;
        if (mode == SYN_EMPTY)
            continue;
        if (mode == SYN_FOAM) { /* dense matter: every ray stops somewhere inside, facing it */
            o->t_hit = o->t_entry + rng_float(&r) * (o->t_exit - o->t_entry);
            o->kind = VX_SAMPLE_INSIDE_FRONT;
            o->normal = v3_scale(d, -1.0f);
            o->albedo = v3(0.5f, 0.5f, 0.5f);
            continue;
        }
        float best = INFINITY;
        int hit = -1;
        for (int k = 0; k < nsh; k++) {
            float dn = v3_dot(sh[k].n, d);
            if (fabsf(dn) < 1e-9f)
                continue;
            float th = (sh[k].offset - v3_dot(sh[k].n, o->origin)) / dn;
            vec3 x = v3_madd(o->origin, d, th);
            if (th < o->t_entry - 1e-5f || th >= best || v3_dot(sh[k].clip_n, x) > sh[k].clip_d)
                continue;
            best = th;
            hit = k;
        }
        if (hit < 0)
            continue;
        const sheet *s = &sh[hit];
        int front = v3_dot(s->n, d) < 0.0f;
        o->t_hit = best;
        o->specular = s->specular;
        o->roughness = s->roughness;
        o->normal = front ? s->n : v3_scale(s->n, -1.0f);
        if (best <= o->t_exit + 1e-5f) {
            o->kind = front || s->double_sided ? VX_SAMPLE_INSIDE_FRONT : VX_SAMPLE_INSIDE_BACK;
            o->albedo = o->kind == VX_SAMPLE_INSIDE_FRONT ? s->albedo : v3(0, 0, 0);
        } else
            o->kind = VX_SAMPLE_OUTSIDE;
    }
}

static vmesh_record bake_synth(int mode, const sheet *sh, int nsh, int n, uint64_t seed)
{
    vx_sample *s = malloc(sizeof *s * (size_t)n);
    synth(mode, sh, nsh, n, seed, s);
    vx_voxel v;
    memset(&v, 0, sizeof v);
    v.lo = v3(0, 0, 0);
    v.size = 1.0f;
    vmesh_record r;
    memset(&r, 0, sizeof r);
    model_vmesh.bake_voxel(&v, s, n, &r);
    free(s);
    return r;
}

static sheet plane_sheet(vec3 n, vec3 point, vec3 albedo)
{
    sheet s;
    memset(&s, 0, sizeof s);
    s.n = v3_normalize(n);
    s.offset = v3_dot(s.n, point);
    s.clip_d = 1.0f; /* clip_n = 0: 0 <= 1 everywhere */
    s.albedo = albedo;
    s.roughness = 0.3f;
    return s;
}

static float opacity_of(const vmesh_record *r, vec3 dir)
{
    vx_query q;
    memset(&q, 0, sizeof q);
    q.ray_dir = v3_normalize(dir);
    q.to_viewer = v3_scale(q.ray_dir, -1.0f);
    return model_vmesh.voxel->opacity.fn(r, &q);
}

/* ---------- subgrid traversal ---------- */

/* The chord's sub-cells by brute force: 20000 points along it, consecutive duplicates dropped. */
static int chord_cells_brute(vec3 e, vec3 d, float len, int *cells)
{
    int m = 0;
    for (int i = 0; i < 20000; i++) {
        vec3 p = v3_madd(e, d, len * ((float)i + 0.5f) / 20000.0f);
        int ix = (int)floorf(p.x), iy = (int)floorf(p.y), iz = (int)floorf(p.z);
        ix = ix < 0 ? 0 : ix > 2 ? 2 : ix, iy = iy < 0 ? 0 : iy > 2 ? 2 : iy, iz = iz < 0 ? 0 : iz > 2 ? 2 : iz;
        int c = (ix * 3 + iy) * 3 + iz;
        if (!m || cells[m - 1] != c)
            cells[m++] = c;
    }
    return m;
}

static void test_traversal(void)
{
    enum { N = 3000 };
    static vx_sample s[N];
    synth(SYN_EMPTY, NULL, 0, N, 21, s);
    int equal = 0, subseq = 1;
    for (int r = 0; r < N; r++) {
        vec3 e = v3_scale(v3_madd(s[r].origin, s[r].dir, s[r].t_entry), 3.0f), d = v3_scale(s[r].dir, 3.0f);
        float len = s[r].t_exit - s[r].t_entry;
        int a[8], b[20000];
        int na = vmesh_chord_cells(e, d, len, a), nb = chord_cells_brute(e, d, len, b);
        int same = na == nb;
        for (int i = 0; same && i < na; i++)
            same = a[i] == b[i];
        equal += same;
        int j = 0; /* brute force may miss a piece shorter than its step, never invent one */
        for (int i = 0; i < na && j < nb; i++)
            j += a[i] == b[j];
        subseq &= j == nb;
    }
    char name[128];
    snprintf(name, sizeof name, "subgrid: DDA = brute-force sub-cells for %d of %d random chords", equal, N);
    CHECK(name, equal >= N - N / 200);
    CHECK("subgrid: brute-force sub-cells always a subsequence of the DDA's", subseq);
    /* Chords along the lattice planes (a ray along a grid plane): x = 1 exactly, along z. */
    int c[8];
    int n = vmesh_chord_cells(v3(1.0f, 1.5f, 0.0f), v3(0, 0, 3.0f), 1.0f, c);
    CHECK("subgrid: chord on the plane x = 1 walks (1,1,0) (1,1,1) (1,1,2)",
          n == 3 && c[0] == 12 && c[1] == 13 && c[2] == 14);
    n = vmesh_chord_cells(v3(0.0f, 1.0f, 1.0f), v3(3.0f, 0, 0), 1.0f, c);
    CHECK("subgrid: chord on the edge y = z = 1 walks x through (., 1, 1)", n == 3 && c[0] == 4 && c[1] == 13 && c[2] == 22);
    n = vmesh_chord_cells(v3(0, 0, 0), v3(3.0f, 3.0f, 3.0f), 1.0f, c);
    CHECK("subgrid: the main diagonal walks the 3 diagonal sub-cells", n == 3 && c[0] == 0 && c[1] == 13 && c[2] == 26);
}

/* ---------- directional opacity ---------- */

static void test_opacity(void)
{
    char name[160];
    rng r = rng_seed(5, 5);
    vec3 dirs[200];
    dirs[0] = v3(1, 0, 0), dirs[1] = v3(0, 1, 0), dirs[2] = v3(0, 0, 1), dirs[3] = v3(1, 1, 0);
    dirs[4] = v3(1, 1, 1), dirs[5] = v3(-1, 1, -1), dirs[6] = v3(0, 1e-7f, 1), dirs[7] = v3(1, 0, 1e-7f);
    for (int i = 8; i < 200; i++)
        dirs[i] = random_sphere(&r);

    /* Dense matter everywhere: with 1000 rays every sub-cell holds front hits (with 150, a corner
     * sub-cell gets none about once in 30 voxels and is cleared: not "full" any more). */
    vmesh_record full = bake_synth(SYN_FOAM, NULL, 0, 1000, 1);
    int all255 = 1;
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        all255 &= full.opacity[c] == 255;
    CHECK("opacity: a voxel full of matter bakes 27 opaque sub-cells", all255);
    float lo = 2, hi = -1;
    for (int i = 0; i < 200; i++) {
        float a = opacity_of(&full, dirs[i]);
        lo = fminf(lo, a), hi = fmaxf(hi, a);
    }
    CHECK_NEAR("opacity: full voxel is 1 from 200 directions (min)", lo, 1.0, 1e-5);
    CHECK_NEAR("opacity: full voxel is 1 from 200 directions (max)", hi, 1.0, 1e-5);

    vmesh_record empty = bake_synth(SYN_EMPTY, NULL, 0, 150, 2);
    hi = 0;
    for (int i = 0; i < 200; i++)
        hi = fmaxf(hi, opacity_of(&empty, dirs[i]));
    CHECK("opacity: empty voxel is 0 from 200 directions", hi == 0.0f && empty.faces == 0);

    /* A uniform sub-cell opacity a reads as a from every direction (what the normalisation buys). */
    vmesh_record uni;
    memset(&uni, 0, sizeof uni);
    memset(uni.opacity, 128, sizeof uni.opacity);
    lo = 2, hi = -1;
    for (int i = 0; i < 200; i++) {
        float a = opacity_of(&uni, dirs[i]);
        lo = fminf(lo, a), hi = fmaxf(hi, a);
    }
    CHECK("opacity: uniform sub-cells 128/255 read as 128/255 everywhere",
          fabsf(lo - 128.0f / 255) < 1e-5f && fabsf(hi - 128.0f / 255) < 1e-5f);

    /* Opposite directions see the same projection. */
    vmesh_record single;
    memset(&single, 0, sizeof single);
    single.opacity[(0 * 3 + 1) * 3 + 2] = 255;
    float asym = 0;
    for (int i = 0; i < 200; i++)
        asym = fmaxf(asym, fabsf(opacity_of(&single, dirs[i]) - opacity_of(&single, v3_scale(dirs[i], -1))));
    CHECK_NEAR("opacity: same from d and -d", asym, 0.0, 1e-6);

    /* The projection alone, on opaque (255) sub-cell blocks whose exact answer is known: the
     * fraction of the voxel's projected footprint covered by the projected block, ratio of the
     * boxes' projected areas (|d.x| ey ez + |d.y| ex ez + |d.z| ex ey). Disks enclose the
     * sub-cubes and each window cell keeps its largest overlap, so the estimate errs high; measured
     * over 2000 directions it stays within [-0.03, +0.14] of the exact value. */
    const struct {
        int i0, i1, j0, j1, k0, k1;
        const char *what;
    } blocks[] = {{0, 3, 0, 3, 0, 1, "bottom third (slab)"},
                  {0, 3, 0, 3, 0, 2, "bottom two thirds (slab)"},
                  {0, 1, 0, 1, 0, 3, "corner column"},
                  {1, 2, 1, 2, 1, 2, "centre sub-cell"}};
    for (size_t bi = 0; bi < sizeof blocks / sizeof blocks[0]; bi++) {
        vmesh_record br;
        memset(&br, 0, sizeof br);
        for (int i = blocks[bi].i0; i < blocks[bi].i1; i++)
            for (int j = blocks[bi].j0; j < blocks[bi].j1; j++)
                for (int k = blocks[bi].k0; k < blocks[bi].k1; k++)
                    br.opacity[(i * 3 + j) * 3 + k] = 255;
        float ex = (float)(blocks[bi].i1 - blocks[bi].i0) / 3, ey = (float)(blocks[bi].j1 - blocks[bi].j0) / 3,
              ez = (float)(blocks[bi].k1 - blocks[bi].k0) / 3;
        double dlo = 1, dhi = -1, mean = 0;
        rng rb = rng_seed(17, bi);
        for (int i = 0; i < 2000; i++) {
            vec3 d = random_sphere(&rb);
            double exact = (fabsf(d.x) * ey * ez + fabsf(d.y) * ex * ez + fabsf(d.z) * ex * ey) /
                           (fabsf(d.x) + fabsf(d.y) + fabsf(d.z));
            double diff = opacity_of(&br, d) - exact;
            dlo = fmin(dlo, diff), dhi = fmax(dhi, diff), mean += diff / 2000;
        }
        printf("# projection of %s: model - exact in [%.3f, %.3f], mean %.3f\n", blocks[bi].what, dlo, dhi, mean);
        snprintf(name, sizeof name, "opacity: projection of the %s within [-0.04, +0.15] of its exact coverage",
                 blocks[bi].what);
        CHECK(name, dlo >= -0.04 && dhi <= 0.15);
        snprintf(name, sizeof name, "opacity: projection of the %s errs high on average (%.3f)", blocks[bi].what, mean);
        CHECK(name, mean > 0.0);
    }

    /* Baked sheets. A plane z = 1/2 across the voxel, and a half plane (x <= 1/2: half the voxel's
     * cross-section), the view turning about y from face-on (0) to edge-on (90 deg). Independent
     * expectation: the fraction of the voxel's projected footprint the projected sheet covers,
     * cos / (cos + sin) and half that. The model is not that: a sub-cell's opacity is the hit rate
     * of rays crossing it from every direction (rays running through the plane's sub-cells on one
     * side of it, away from it, count as misses), so the plane's sub-cells hold about 0.8, face-on
     * reads low, and the max over sub-disks keeps the sheet 0.3-0.45 opaque edge-on where the truth
     * is 0: the thicker occluders the paper reports. What is checked: the special pass keeps only
     * the plane's layer; face-on = the layer's stored opacity; the curve falls as the view turns;
     * conservative from 50 degrees on; the half plane below the plane. */
    sheet plane = plane_sheet(v3(0, 0, 1), v3(0.5f, 0.5f, 0.5f), v3(0.8f, 0.5f, 0.2f));
    vmesh_record pr = bake_synth(SYN_PLANES, &plane, 1, 150, 3);
    int layer_only = 1;
    float layer_mean = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++) {
                int o = pr.opacity[(i * 3 + j) * 3 + k];
                layer_only &= k == 1 ? o > 127 : o == 0;
                if (k == 1)
                    layer_mean += (float)o / 255.0f / 9.0f;
            }
    snprintf(name, sizeof name, "opacity: plane bakes its own layer only (mean opacity %.3f), the rest cleared",
             layer_mean);
    CHECK(name, layer_only);
    sheet half = plane;
    half.clip_n = v3(1, 0, 0);
    half.clip_d = 0.5f;
    vmesh_record hr = bake_synth(SYN_PLANES, &half, 1, 150, 4);
    int plane_conservative = 1, half_conservative = 1, plane_trend = 1, half_trend = 1, half_below = 1;
    float plane_prev = 2.0f, half_prev = 2.0f, plane_face = 0, half_face = 0, plane_edge = 0;
    printf("# directional opacity vs view angle from the plane normal (rotation about y)\n");
    printf("# deg   plane: model expected   half plane: model expected\n");
    for (int deg = 0; deg <= 90; deg += 10) {
        double th = deg * PI / 180.0;
        vec3 d = v3((float)sin(th), 0.0f, (float)cos(th));
        double ep = cos(th) / (cos(th) + sin(th)), eh = 0.5 * ep;
        float mp = opacity_of(&pr, d), mh = opacity_of(&hr, d);
        printf("# %3d   %.3f %.3f   %.3f %.3f\n", deg, mp, ep, mh, eh);
        if (deg >= 50) {
            plane_conservative &= mp >= ep;
            half_conservative &= mh >= eh;
        }
        /* Towards edge-on the sheet's three columns project onto the same disks and the half plane
         * turns into the plane (the max does not add them up): the trend is checked before that. */
        if (deg <= 80)
            plane_trend &= mp <= plane_prev + 0.02f;
        if (deg <= 60)
            half_trend &= mh <= half_prev + 0.02f;
        half_below &= mh <= mp + 0.02f;
        plane_prev = mp, half_prev = mh;
        if (deg == 0)
            plane_face = mp, half_face = mh;
        if (deg == 90)
            plane_edge = mp;
    }
    CHECK_NEAR("opacity: plane face-on = its layer's stored opacity", plane_face, layer_mean, 0.02);
    CHECK("opacity: plane falls (within 0.02) from face-on to 80 degrees", plane_trend);
    CHECK("opacity: half plane falls (within 0.02) from face-on to 60 degrees", half_trend);
    CHECK("opacity: plane at or above its coverage from 50 degrees on (conservative)", plane_conservative);
    CHECK("opacity: half plane at or above its coverage from 50 degrees on (conservative)", half_conservative);
    snprintf(name, sizeof name, "opacity: plane edge-on %.3f in [0.25, 0.6] (truth 0: thick occluders)", plane_edge);
    CHECK(name, plane_edge >= 0.25f && plane_edge <= 0.6f);
    snprintf(name, sizeof name, "opacity: half plane face-on %.3f within 0.1 of its coverage 0.5", half_face);
    CHECK(name, fabsf(half_face - 0.5f) <= 0.1f);
    CHECK("opacity: half plane never above the plane (within 0.02)", half_below);
}

/* ---------- faces and shading ---------- */

static vx_query light_query(vec3 to_viewer, vec3 to_light, vec3 irradiance, unsigned effects)
{
    vx_query q;
    memset(&q, 0, sizeof q);
    q.to_viewer = v3_normalize(to_viewer);
    q.ray_dir = v3_scale(q.to_viewer, -1.0f);
    q.effects = effects;
    q.light_count = 1;
    q.to_light[0] = v3_normalize(to_light);
    q.irradiance[0] = irradiance;
    return q;
}

static vec3 shade_of(const vmesh_record *r, const vx_query *q)
{
    vx_answer a;
    memset(&a, 0, sizeof a);
    a.opacity = model_vmesh.voxel->opacity.fn(r, q);
    model_vmesh.voxel->shade.fn(r, q, &a);
    return a.radiance;
}

static double rel_err(vec3 got, vec3 want)
{
    double e = 0;
    e = fmax(e, fabs(got.x - want.x) / fmax(fabs(want.x), 1e-3));
    e = fmax(e, fabs(got.y - want.y) / fmax(fabs(want.y), 1e-3));
    e = fmax(e, fabs(got.z - want.z) / fmax(fabs(want.z), 1e-3));
    return e;
}

static int finite3(vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

static void test_shading(void)
{
    char name[160];
    vec3 E = v3(3.0f, 2.9f, 2.7f), col = v3(0.8f, 0.5f, 0.2f);
    vec3 n = v3_normalize(v3(0.3f, 0.2f, 0.93f));
    sheet pl = plane_sheet(n, v3(0.5f, 0.5f, 0.5f), col);
    pl.specular = 0.04f;
    pl.roughness = 0.3f;
    vmesh_record r = bake_synth(SYN_PLANES, &pl, 1, 150, 7);
    int faces = 0;
    for (int f = 0; f < 8; f++)
        faces += (r.faces >> f) & 1;
    CHECK("faces: one plane fills one face with one distinct normal", faces == 1 && r.distribution == 0);

    /* From the front: Lambert of the plane (normal n, colour col), whatever the view. */
    vec3 t, b;
    v3_basis(n, &t, &b);
    const vec3 lights[3] = {n, v3_add(n, v3_scale(t, 0.8f)), v3_add(n, v3_scale(b, -1.5f))};
    const float view_deg[4] = {0, 40, 75, 87};
    double worst = 0;
    for (int li = 0; li < 3; li++)
        for (int vi = 0; vi < 4; vi++) {
            float th = view_deg[vi] * (float)PI / 180.0f;
            vec3 w = v3_add(v3_scale(n, cosf(th)), v3_scale(v3_add(t, b), sinf(th) * 0.70710678f));
            vx_query q = light_query(w, lights[li], E, 0);
            float cl = fmaxf(0.0f, v3_dot(n, q.to_light[0]));
            vec3 want = v3_scale(v3_mul(col, E), cl / (float)PI);
            vec3 got = shade_of(&r, &q);
            worst = fmax(worst, rel_err(got, want));
        }
    snprintf(name, sizeof name, "shading: plane from the front (views 0-87 deg) = Lambert of the plane (rel err %.4f)",
             worst);
    CHECK(name, worst < 0.03);

    /* With "specular": Lambert + the Beckmann lobe of the plane's normal. */
    worst = 0;
    for (int vi = 0; vi < 3; vi++) {
        float th = view_deg[vi] * (float)PI / 180.0f;
        vec3 w = v3_add(v3_scale(n, cosf(th)), v3_scale(t, -sinf(th)));
        vx_query q = light_query(w, lights[1], E, VX_EFFECT_SPECULAR);
        float cl = fmaxf(0.0f, v3_dot(n, q.to_light[0]));
        float s = shading_specular_brdf(n, q.to_viewer, q.to_light[0], 0.04f, 0.3f);
        vec3 want = v3_scale(v3_mul(v3_add(v3_scale(col, 1.0f / (float)PI), v3(s, s, s)), E), cl);
        worst = fmax(worst, rel_err(shade_of(&r, &q), want));
    }
    snprintf(name, sizeof name, "shading: plane with specular = Lambert + Beckmann of the plane (rel err %.4f)", worst);
    CHECK(name, worst < 0.05);

    /* Light behind the plane, viewer in front: nothing lit, no leak (Figure 10, bottom). */
    vx_query q = light_query(n, v3_scale(lights[1], -1.0f), E, 0);
    vec3 dark = shade_of(&r, &q);
    CHECK("shading: light behind the plane, viewer in front: black", dark.x == 0 && dark.y == 0 && dark.z == 0);

    /* Viewer behind a single-sided plane: no face faces the viewer, a dark occluder. */
    q = light_query(v3_scale(n, -1.0f), v3_scale(n, -1.0f), E, 0);
    vec3 back = shade_of(&r, &q);
    float back_op = opacity_of(&r, n), front_op = opacity_of(&r, v3_scale(n, -1.0f));
    CHECK("shading: seen from behind, single-sided plane is black", back.x == 0 && back.y == 0 && back.z == 0);
    snprintf(name, sizeof name, "shading: seen from behind it occludes as from the front (opacity %.3f)", back_op);
    CHECK(name, back_op > 0.4f && back_op == front_op);

    /* Double-sided: the back shades like a plane of normal -n. */
    pl.double_sided = 1;
    vmesh_record ds = bake_synth(SYN_PLANES, &pl, 1, 150, 8);
    q = light_query(v3_scale(n, -1.0f), v3_scale(lights[2], -1.0f), E, 0);
    float cl = fmaxf(0.0f, v3_dot(v3_scale(n, -1.0f), q.to_light[0]));
    double e2 = rel_err(shade_of(&ds, &q), v3_scale(v3_mul(col, E), cl / (float)PI));
    snprintf(name, sizeof name, "shading: double-sided plane from behind = Lambert of -n (rel err %.4f)", e2);
    CHECK(name, e2 < 0.03);

    /* A crease: half the voxel faces +x, half +z (two planes meeting at the voxel's centre line).
     * Seen along +x with the light along +x, only the +x side is visible and lit. */
    sheet cr[2] = {plane_sheet(v3(1, 0, 0), v3(0.5f, 0.5f, 0.5f), col), plane_sheet(v3(0, 0, 1), v3(0.5f, 0.5f, 0.5f), col)};
    cr[0].clip_n = v3(0, 0, 1), cr[0].clip_d = 0.5f;  /* x = 1/2 for z <= 1/2 */
    cr[1].clip_n = v3(-1, 0, 0), cr[1].clip_d = -0.5f; /* z = 1/2 for x >= 1/2 */
    vmesh_record crr = bake_synth(SYN_PLANES, cr, 2, 150, 9);
    q = light_query(v3(1, 0, 0), v3(1, 0, 0.3f), E, 0);
    cl = v3_dot(v3(1, 0, 0), q.to_light[0]);
    double e3 = rel_err(shade_of(&crr, &q), v3_scale(v3_mul(col, E), cl / (float)PI));
    snprintf(name, sizeof name, "shading: crease seen along one side's normal = that side's Lambert (rel err %.4f)", e3);
    CHECK(name, e3 < 0.05);

    /* Two distinct normals in one face (a building's edge: +x and +z, half the hits each): both
     * facing the viewer, each nearest-vertex region is half the face, so the voxel is the mean of
     * the two Lamberts, as the two equal, equally foreshortened facets are seen from (1, 0, 1). */
    {
        enum { K = 150 };
        vx_sample ks[K];
        synth(SYN_FOAM, NULL, 0, K, 12, ks);
        for (int i = 0; i < K; i++) {
            ks[i].normal = i % 2 ? v3(1, 0, 0) : v3(0, 0, 1);
            ks[i].albedo = col;
        }
        vx_voxel kv;
        memset(&kv, 0, sizeof kv);
        kv.size = 1.0f;
        vmesh_record edge;
        memset(&edge, 0, sizeof edge);
        model_vmesh.bake_voxel(&kv, ks, K, &edge);
        vx_query qe = light_query(v3(1, 0, 1), v3(1.0f, 0.3f, 0.4f), E, 0);
        float lx = qe.to_light[0].x, lz = qe.to_light[0].z;
        vec3 want2 = v3_scale(v3_mul(col, E), 0.5f * (lx + lz) / (float)PI);
        double e6 = rel_err(shade_of(&edge, &qe), want2);
        snprintf(name, sizeof name, "shading: edge with normals +x, +z from (1,0,1) = mean of both Lamberts (rel err %.4f)",
                 e6);
        CHECK(name, e6 < 0.02);
        qe = light_query(v3(0, 0, 1), v3(1.0f, 0.3f, 0.4f), E, 0);
        want2 = v3_scale(v3_mul(col, E), lz / (float)PI);
        e6 = rel_err(shade_of(&edge, &qe), want2);
        snprintf(name, sizeof name, "shading: same edge seen along +z = the +z facet's Lambert (rel err %.4f)", e6);
        CHECK(name, e6 < 0.02);
    }

    /* A distribution: normals uniform on a 35-degree cap (a bumpy surface, one colour). Seen and lit
     * along the cap axis, the exact answer is col E / pi times the mean of (n.l) weighted by the
     * normals' projected area (n.w): E[cos^3] / E[cos^2] over the cap. The octahedron sees it
     * through three extremal normals per face, so only a loose match is expected. */
    float a = 35.0f * (float)PI / 180.0f;
    enum { M = 150 };
    vx_sample s[M];
    rng rr = rng_seed(3, 3);
    synth(SYN_FOAM, NULL, 0, M, 10, s);
    for (int i = 0; i < M; i++) {
        s[i].normal = random_cap(&rr, a);
        s[i].albedo = col;
    }
    vx_voxel v;
    memset(&v, 0, sizeof v);
    v.size = 1.0f;
    vmesh_record dist;
    memset(&dist, 0, sizeof dist);
    model_vmesh.bake_voxel(&v, s, M, &dist);
    CHECK("faces: a cap of normals makes distribution faces", dist.distribution != 0);
    double c0 = cos(a), m2 = (1 - c0 * c0 * c0) / 3 / (1 - c0), m3 = (1 - c0 * c0 * c0 * c0) / 4 / (1 - c0);
    q = light_query(v3(0, 0, 1), v3(0, 0, 1), E, 0);
    vec3 want = v3_scale(v3_mul(col, E), (float)(m3 / m2 / PI));
    vec3 got = shade_of(&dist, &q);
    double e4 = rel_err(got, want);
    snprintf(name, sizeof name, "shading: 35-degree cap lit and seen along its axis within 10%% (rel err %.4f)", e4);
    CHECK(name, e4 < 0.10);
    /* Lit from 60 degrees off the axis: mean of max(0, n.l) weighted by n.w, by quadrature. */
    vec3 l60 = v3(sinf(1.0472f), 0, cosf(1.0472f));
    double num = 0, den = 0;
    for (int i = 0; i < 200000; i++) {
        vec3 nn = random_cap(&rr, a);
        num += nn.z * fmax(0.0, v3_dot(nn, l60));
        den += nn.z;
    }
    q = light_query(v3(0, 0, 1), l60, E, 0);
    want = v3_scale(v3_mul(col, E), (float)(num / den / PI));
    double e5 = rel_err(shade_of(&dist, &q), want);
    snprintf(name, sizeof name, "shading: 35-degree cap lit from 60 degrees within 10%% (rel err %.4f)", e5);
    CHECK(name, e5 < 0.10);

    /* Every direction: finite radiance and opacity in [0, 1], no random numbers (same twice). */
    int ok = 1;
    rng rd = rng_seed(9, 9);
    const vmesh_record *recs[4] = {&r, &ds, &crr, &dist};
    for (int i = 0; i < 400 && ok; i++) {
        vec3 w = i < 6 ? v3(i == 0 ? 1.f : i == 1 ? -1.f : 0.f, i == 2 ? 1.f : i == 3 ? -1.f : 0.f, i == 4 ? 1.f : i == 5 ? -1.f : 0.f)
                       : random_sphere(&rd);
        vx_query qq = light_query(w, random_sphere(&rd), E, VX_EFFECT_SPECULAR);
        for (int k = 0; k < 4; k++) {
            vec3 c1 = shade_of(recs[k], &qq), c2 = shade_of(recs[k], &qq);
            float o1 = model_vmesh.voxel->opacity.fn(recs[k], &qq);
            ok &= finite3(c1) && c1.x >= 0 && c1.y >= 0 && c1.z >= 0 && c1.x == c2.x && c1.y == c2.y && c1.z == c2.z;
            ok &= o1 >= 0.0f && o1 <= 1.0f;
        }
    }
    CHECK("shading: finite, non-negative, deterministic from 400 directions", ok);
}

/* ---------- end to end: the real sampler on a one-quad scene ---------- */

static int write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (!f)
        return -1;
    fputs(text, f);
    return fclose(f);
}

static void test_real_sampler(void)
{
    const char *tmp = getenv("TEST_TMP");
    char dir[512], ply[600], json[600];
    snprintf(dir, sizeof dir, "%s", tmp && *tmp ? tmp : "/tmp");
    char cmd[700];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", dir);
    if (system(cmd) != 0) {
        CHECK("real sampler: temp dir", 0);
        return;
    }
    snprintf(ply, sizeof ply, "%s/vmesh_quad.ply", dir);
    snprintf(json, sizeof json, "%s/vmesh_quad.json", dir);
    /* A tilted unit quad (normal (0, sin 20, cos 20)) plus a small marker cube that fixes the
     * scene's bounds, so that the quad crosses voxels away from the grid's edges. */
    if (write_file(ply, "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                        "-1 -0.9397 0.3420\n1 -0.9397 0.3420\n1 0.9397 -0.3420\n-1 0.9397 -0.3420\n4 0 1 2 3\n") ||
        write_file(json, "{\"name\": \"vmesh_quad\", \"size\": [16, 16], \"background\": [0, 0, 0],"
                         "\"camera\": {\"position\": [0, 0, 5], \"look_at\": [0, 0, 0], \"up\": [0, 1, 0], \"fov_deg\": 40},"
                         "\"lights\": [{\"type\": \"directional\", \"direction\": [0, 0.3, 1], \"irradiance\": [2, 2, 2]}],"
                         "\"materials\": {\"m\": {\"color\": [0.6, 0.4, 0.3]}},"
                         "\"objects\": [{\"ply\": \"vmesh_quad.ply\", \"material\": \"m\"}]}")) {
        CHECK("real sampler: scene files written", 0);
        return;
    }
    scene sc;
    rt_scene rt;
    voxel_grid g;
    vx_err e;
    memset(&sc, 0, sizeof sc);
    memset(&rt, 0, sizeof rt);
    memset(&g, 0, sizeof g);
    if (scene_load(json, &sc, &e) || rt_build(&rt, &sc, &e) || grid_build(&g, &sc.mesh, 16, &e)) {
        printf("# %s\n", e.msg);
        CHECK("real sampler: scene loads and voxelises", 0);
        return;
    }
    bake_options o = {.rays = 150, .seed = 1, .threads = 2};
    void *records = NULL;
    bake_counts counts;
    if (bake_run(&rt, &g, &model_vmesh, &o, &records, &counts, &e)) {
        CHECK("real sampler: bake runs", 0);
        return;
    }
    /* The voxel holding the quad's centre (the origin). */
    double l[3];
    grid_to_lattice(&g, v3(0, 0, 0), l);
    int64_t idx = grid_index(&g, 0, (int)l[0], (int)l[1], (int)l[2]);
    CHECK("real sampler: the quad's centre voxel is non-empty", idx >= 0);
    if (idx >= 0) {
        const vmesh_record *r = (const vmesh_record *)records + idx;
        vec3 n = v3(0, 0.3420f, 0.9397f);
        vx_query q = light_query(n, v3(0, 0.3f, 1), v3(2, 2, 2), 0);
        float cl = v3_dot(n, q.to_light[0]);
        vec3 want = v3_scale(v3(0.6f, 0.4f, 0.3f), 2.0f * cl / (float)PI);
        double err = rel_err(shade_of(r, &q), want);
        char name[160];
        snprintf(name, sizeof name, "real sampler: quad voxel shades as Lambert of the quad (rel err %.4f)", err);
        CHECK(name, err < 0.03);
        float front = opacity_of(r, n), back = opacity_of(r, v3_scale(n, -1));
        snprintf(name, sizeof name, "real sampler: quad voxel occludes face-on (%.3f), same from behind", front);
        CHECK(name, front > 0.5f && fabsf(front - back) < 1e-6f);
        q = light_query(v3_scale(n, -1), v3(0, 0.3f, 1), v3(2, 2, 2), 0);
        vec3 bk = shade_of(r, &q);
        CHECK("real sampler: single-sided quad from behind is black", bk.x == 0 && bk.y == 0 && bk.z == 0);
    }
    free(records);
    grid_free(&g);
    rt_free(&rt);
    scene_free(&sc);
}

int main(void)
{
    CHECK("record: 139 bytes, no padding", sizeof(vmesh_record) == 139 && model_vmesh.record.bytes == 139);
    test_sggx();
    test_portable_acos();
    test_overlap();
    test_traversal();
    test_opacity();
    test_shading();
    test_real_sampler();
    return unit_exit();
}
