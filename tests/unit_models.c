/* The hard-case table: every model in model_all() is run through one table of synthetic voxels
 * (sample sets) and queries (view, lights, irradiance, effects, footprint), so a newly registered
 * model is covered without editing this file.
 *
 * Every answer must be finite, opacity in [0, 1], radiance >= 0 and below a bound derived here from
 * the physics, not from the models: per light, max irradiance x (2 x max albedo / pi + 2 x f0 x
 * D_max x G_sup) where D_max is the Beckmann peak and G_sup the supremum of G2 / (4 n.v) for the
 * smallest roughness among the voxel's hits, both computed in double with the exact Smith Lambda.
 * (Lambert's maximum is albedo / pi; the factor 2 leaves room for models that redistribute light
 * like a phase function. The specular term appears only when the scene declares "specular".)
 *
 * Then independent facts about the two baselines, taken from their documented definitions: alpha's
 * opacity is the fraction of occluding samples when a front face was hit (else 0), binary's is 1
 * exactly when a front face was hit; and
 * the registry's invariants. */
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "bake_params.h"
#include "grid.h"
#include "mesh.h"
#include "model.h"
#include "unit.h"
#include "voxfile.h"

/* ---------- the test's own random numbers (xorshift64*, independent of tracer/core/rng.h) ---------- */

static uint64_t rnd_u64(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return *s * 0x2545F4914F6CDD1DULL;
}
static double rnd01(uint64_t *s) { return (double)(rnd_u64(s) >> 11) * (1.0 / 9007199254740992.0); }

/* Uniform on the sphere: a normalised Gaussian vector (Box-Muller), a different construction from
 * the bake sampler's (z, phi). */
static vec3 rnd_dir(uint64_t *s)
{
    for (;;) {
        double g[3];
        for (int k = 0; k < 3; k++) {
            double u = rnd01(s), v = rnd01(s);
            g[k] = sqrt(-2.0 * log(u + 1e-300)) * cos(2.0 * M_PI * v);
        }
        double len = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        if (len > 1e-6)
            return v3((float)(g[0] / len), (float)(g[1] / len), (float)(g[2] / len));
    }
}

/* ---------- synthetic voxels ---------- */

typedef struct {
    const char *name;
    double lo[3]; /* lower corner (double: the test's own geometry) */
    double size;
} geometry;

static const geometry geometries[] = {
    {"unit", {0, 0, 0}, 1.0},
    {"tiny 1e-6", {0, 0, 0}, 1e-6},
    {"huge 1e6", {-5e5, -5e5, -5e5}, 1e6},
    {"far 1e6", {1e6, 1e6 + 1, 1e6 - 1}, 1.0},
    {"far and tiny", {1e6, 1e6, 1e6}, 1e-6},
};

typedef void (*fill_fn)(vx_sample *s, int i, uint64_t *r);

enum { EXPECT_NONE = 0, EXPECT_EMPTY = 1, EXPECT_FULL = 2 };

typedef struct {
    const char *name;
    int n;
    fill_fn fill;
    int expect;
} bake_case;

static void front(vx_sample *s, vec3 normal, vec3 albedo, float spec, float rough)
{
    s->kind = VX_SAMPLE_INSIDE_FRONT;
    s->normal = normal;
    s->albedo = albedo;
    s->specular = spec;
    s->roughness = rough;
}

static void back(vx_sample *s, vec3 normal)
{
    s->kind = VX_SAMPLE_INSIDE_BACK;
    s->normal = normal;
    s->albedo = v3(0, 0, 0); /* the sampler gives back faces of single-sided surfaces no colour */
    s->specular = 0.04f;
    s->roughness = 0.3f;
}

static const vec3 ORANGE = {0.8f, 0.5f, 0.2f};

static void fill_miss(vx_sample *s, int i, uint64_t *r)
{
    (void)i, (void)r;
    s->kind = VX_SAMPLE_MISS;
}
static void fill_outside(vx_sample *s, int i, uint64_t *r)
{
    (void)i, (void)r;
    s->kind = VX_SAMPLE_OUTSIDE;
    s->t_hit = s->t_exit + (s->t_exit - s->t_entry) + 1.0f;
    s->normal = v3_scale(s->dir, -1.0f);
    s->specular = 0.04f;
    s->roughness = 0.3f;
}
/* A flat surface through the voxel, every sample a front hit (one normal). */
static void fill_one_normal(vx_sample *s, int i, uint64_t *r)
{
    (void)i, (void)r;
    front(s, v3(0, 0, 1), ORANGE, 0.04f, 0.3f);
}
/* A single-sided plane: rays from above see its front, rays from below its back. */
static void fill_single_sided_plane(vx_sample *s, int i, uint64_t *r)
{
    (void)i, (void)r;
    if (s->dir.z < 0.0f)
        front(s, v3(0, 0, 1), ORANGE, 0.04f, 0.3f);
    else
        back(s, v3(0, 0, -1));
}
/* Two opposite normals in equal numbers: their mean is exactly zero. */
static void fill_two_opposite(vx_sample *s, int i, uint64_t *r)
{
    (void)r;
    front(s, v3(0, 0, i % 2 ? -1.0f : 1.0f), ORANGE, 0.04f, 0.3f);
}
/* A small sphere inside the voxel: normals face the incoming rays, covering the full sphere. */
static void fill_sphere_normals(vx_sample *s, int i, uint64_t *r)
{
    (void)i, (void)r;
    front(s, v3_scale(s->dir, -1.0f), ORANGE, 0.04f, 0.3f);
}
/* Normals uniform on the sphere, independent of the ray (foliage-like). */
static void fill_random_normals(vx_sample *s, int i, uint64_t *r)
{
    (void)i;
    front(s, rnd_dir(r), ORANGE, 0.04f, 0.3f);
}
/* A solid block filling the voxel: every ray hits the face it enters through. */
static void fill_full_box(vx_sample *s, int i, uint64_t *r)
{
    (void)i, (void)r;
    vec3 d = s->dir;
    int k = fabsf(d.x) >= fabsf(d.y) && fabsf(d.x) >= fabsf(d.z) ? 0 : (fabsf(d.y) >= fabsf(d.z) ? 1 : 2);
    float sign = v3_get(d, k) > 0 ? -1.0f : 1.0f;
    vec3 n = v3(k == 0 ? sign : 0.0f, k == 1 ? sign : 0.0f, k == 2 ? sign : 0.0f);
    front(s, n, v3(0.3f, 0.6f, 0.9f), 0.5f, 0.2f);
}
static void fill_back_only(vx_sample *s, int i, uint64_t *r)
{
    (void)i, (void)r;
    back(s, v3(0, 0, s->dir.z < 0.0f ? 1.0f : -1.0f));
}
static void fill_zero_normals(vx_sample *s, int i, uint64_t *r)
{
    (void)i, (void)r;
    front(s, v3(0, 0, 0), ORANGE, 0.04f, 0.3f);
}
/* A mirror-like surface: full Fresnel reflectance, roughness 1e-4 (a peak of ~3e7 in D). */
static void fill_tiny_roughness(vx_sample *s, int i, uint64_t *r)
{
    (void)i, (void)r;
    front(s, v3(0, 0, 1), v3(1, 1, 1), 1.0f, 1e-4f);
}
/* Everything at once: front, back, miss and outside samples with random colours and materials. */
static void fill_mixed(vx_sample *s, int i, uint64_t *r)
{
    switch (i % 4) {
    case 0:
        front(s, rnd_dir(r), v3((float)rnd01(r), (float)rnd01(r), (float)rnd01(r)), (float)rnd01(r),
              (float)(0.05 + 0.95 * rnd01(r)));
        break;
    case 1:
        back(s, rnd_dir(r));
        break;
    case 2:
        fill_miss(s, i, r);
        break;
    default:
        fill_outside(s, i, r);
    }
}
/* Half the rays hit the flat surface, half miss: a partially covered voxel. */
static void fill_half(vx_sample *s, int i, uint64_t *r)
{
    if (i % 2)
        fill_miss(s, i, r);
    else
        fill_one_normal(s, i, r);
}

static const bake_case cases[] = {
    {"empty (all MISS)", 150, fill_miss, EXPECT_EMPTY},
    {"all OUTSIDE", 150, fill_outside, EXPECT_NONE}, /* case (b) only: no front hit, so transparent (0) */
    {"one normal", 150, fill_one_normal, EXPECT_FULL},
    {"half covered", 150, fill_half, EXPECT_NONE},
    {"single-sided plane", 150, fill_single_sided_plane, EXPECT_NONE},
    {"two opposite normals", 150, fill_two_opposite, EXPECT_FULL},
    {"sphere of normals", 150, fill_sphere_normals, EXPECT_FULL},
    {"random normals", 150, fill_random_normals, EXPECT_FULL},
    {"fully occluding", 150, fill_full_box, EXPECT_FULL},
    {"only back faces", 150, fill_back_only, EXPECT_NONE},
    {"zero-length normals", 150, fill_zero_normals, EXPECT_FULL},
    {"tiny roughness", 150, fill_tiny_roughness, EXPECT_FULL},
    {"mixed", 4096, fill_mixed, EXPECT_NONE},
    {"single sample (hit)", 1, fill_one_normal, EXPECT_FULL},
    {"single sample (miss)", 1, fill_miss, EXPECT_EMPTY},
    {"zero samples", 0, fill_miss, EXPECT_EMPTY},
};

/* Slab test in double of the line p + t d against the box [lo, lo + size]^3. */
static int slab(const double p[3], vec3 d, const double lo[3], double size, double *t0, double *t1)
{
    double a = -INFINITY, b = INFINITY;
    for (int k = 0; k < 3; k++) {
        double dk = v3_get(d, k);
        if (dk == 0.0) {
            if (p[k] < lo[k] || p[k] > lo[k] + size)
                return 0;
            continue;
        }
        double u = (lo[k] - p[k]) / dk, v = (lo[k] + size - p[k]) / dk;
        if (u > v) {
            double t = u;
            u = v;
            v = t;
        }
        a = fmax(a, u);
        b = fmin(b, v);
    }
    *t0 = a;
    *t1 = b;
    return a <= b;
}

/* n samples for a voxel: directions uniform, lines through a uniform point of the voxel, origins
 * 4 voxel sizes back, then the case's kinds, normals and colours. */
static void make_samples(const bake_case *c, const geometry *geo, uint64_t seed, vx_sample *out)
{
    uint64_t r = seed * 0x9E3779B97F4A7C15ULL + 1;
    for (int i = 0; i < c->n; i++) {
        vx_sample *s = &out[i];
        memset(s, 0, sizeof *s);
        vec3 d = rnd_dir(&r);
        double p[3], o[3], t0 = 0, t1 = 0;
        for (int k = 0; k < 3; k++)
            p[k] = geo->lo[k] + geo->size * rnd01(&r);
        for (int k = 0; k < 3; k++)
            o[k] = p[k] - 4.0 * geo->size * v3_get(d, k);
        slab(o, d, geo->lo, geo->size, &t0, &t1);
        s->origin = v3((float)o[0], (float)o[1], (float)o[2]);
        s->dir = d;
        s->t_entry = (float)t0;
        s->t_exit = (float)t1;
        s->t_hit = INFINITY;
        s->kind = VX_SAMPLE_MISS;
        c->fill(s, i, &r);
        if (s->kind == VX_SAMPLE_INSIDE_FRONT || s->kind == VX_SAMPLE_INSIDE_BACK)
            s->t_hit = 0.5f * (s->t_entry + s->t_exit);
    }
}

/* ---------- the physical bound ---------- */

/* Smith's Lambda for Beckmann slopes of per-axis deviation sigma, exact, in double. */
static double smith_lambda(double c, double sigma)
{
    double mu = c / sqrt(fmax(1e-300, 1.0 - c * c));
    return 0.5 * (sqrt(2.0 / M_PI) * sigma / mu * exp(-mu * mu / (2.0 * sigma * sigma)) -
                  erfc(mu / (M_SQRT2 * sigma)));
}

/* Beckmann D peak over cos_h in (0, 1] (1 / (pi alpha^2) for alpha < 1/sqrt(2), off-axis above). */
static double beckmann_max(double alpha)
{
    double best = 0;
    for (int i = 1; i <= 20000; i++) {
        double c = (double)i / 20000.0, c2 = c * c;
        double d = exp(-(1.0 - c2) / c2 / (alpha * alpha)) / (M_PI * alpha * alpha * c2 * c2);
        best = fmax(best, d);
    }
    return best;
}

/* sup over n.v in (0, 1] of G1 / (4 n.v) = 1 / (4 c (1 + Lambda(c))): finite because Lambda grows
 * like sigma / c at grazing angles (the height-correlated G2 only adds Lambda(n.l) >= 0). A log
 * grid from 1e-30 to 1 with 40 points a decade; smooth, so the factor 2 of the bound covers it. */
static double g_over_nv_sup(double alpha)
{
    double sigma = alpha / M_SQRT2, best = 0;
    for (int i = 0; i <= 1200; i++) {
        double c = pow(10.0, -30.0 + (double)i / 40.0);
        if (c > 1.0)
            c = 1.0;
        best = fmax(best, 1.0 / (4.0 * c * (1.0 + fmax(0.0, smith_lambda(c, sigma)))));
    }
    return best;
}

typedef struct {
    double albedo_max, f0_max, spec_peak; /* spec_peak = D_max * G_sup at the smallest roughness */
    int inside, front, occluding, n; /* occluding: cases (a) and (b) of the classification */
} sample_summary;

static void summarise(const vx_sample *s, int n, sample_summary *out)
{
    memset(out, 0, sizeof *out);
    out->n = n;
    double alpha_min = INFINITY;
    for (int i = 0; i < n; i++) {
        out->albedo_max = fmax(out->albedo_max, fmax(s[i].albedo.x, fmax(s[i].albedo.y, s[i].albedo.z)));
        int hit = s[i].kind == VX_SAMPLE_INSIDE_FRONT || s[i].kind == VX_SAMPLE_INSIDE_BACK;
        out->inside += hit;
        out->front += s[i].kind == VX_SAMPLE_INSIDE_FRONT;
        out->occluding += hit || s[i].kind == VX_SAMPLE_OUTSIDE;
        if (hit) {
            out->f0_max = fmax(out->f0_max, s[i].specular);
            alpha_min = fmin(alpha_min, s[i].roughness);
        }
    }
    if (out->f0_max > 0)
        out->spec_peak = beckmann_max(alpha_min) * g_over_nv_sup(alpha_min);
}

/* ---------- queries ---------- */

typedef struct {
    const char *name;
    double c; /* cosine to +z, the reference surface normal of the cases */
} angle;

/* 0 deg, 45, 89.9, exactly 90, "90" with tiny positive cosines (what float dot products at a
 * silhouette give), and behind the surface. */
static const angle angles[] = {
    {"0", 1.0}, {"45", 0.70710678118654752}, {"89.9", 0.0017453283658983088}, {"90", 0.0},
    {"90-1e-12", 1e-12}, {"90-1e-23", 1e-23}, {"135", -0.70710678118654752}, {"180", -1.0},
};
enum { ANGLES = sizeof angles / sizeof angles[0] };

/* Azimuth 0 (x), 90 (y) or 180 (-x). */
static vec3 direction(double c, int azimuth)
{
    double s = sqrt(fmax(0.0, 1.0 - c * c));
    switch (azimuth) {
    case 90:
        return v3(0.0f, (float)s, (float)c);
    case 180:
        return v3((float)-s, 0.0f, (float)c);
    default:
        return v3((float)s, 0.0f, (float)c);
    }
}

typedef struct {
    const char *name;
    vec3 value;
} level;

static const level irradiances[] = {{"E=0", {0, 0, 0}}, {"E=(1,.5,.25)", {1.0f, 0.5f, 0.25f}}, {"E=1e12", {1e12f, 1e12f, 1e12f}}};
static const unsigned effect_sets[] = {0, VX_EFFECT_SPECULAR,
                                       VX_EFFECT_SHADOWS | VX_EFFECT_SPECULAR | VX_EFFECT_DOF | VX_EFFECT_TEXTURES};
static const double footprints[] = {0.0, 0.5, 1e9}; /* x voxel size */

/* Light set k for a view: 0 = no light; 1..ANGLES = one light at the mirror azimuth (the specular
 * peak for the one-normal cases); ANGLES+1..2*ANGLES = one at azimuth 90; last = VX_MAX_LIGHTS. */
enum { LIGHT_SETS = 2 + 2 * ANGLES };

static void set_lights(vx_query *q, int k, vec3 E, char *desc, size_t desc_size)
{
    if (k == 0) {
        q->light_count = 0;
        snprintf(desc, desc_size, "no light");
    } else if (k <= 2 * ANGLES) {
        int a = (k - 1) % ANGLES, az = k <= ANGLES ? 180 : 90;
        q->light_count = 1;
        q->to_light[0] = direction(angles[a].c, az);
        q->irradiance[0] = E;
        snprintf(desc, desc_size, "light at %s deg azimuth %d", angles[a].name, az);
    } else {
        q->light_count = VX_MAX_LIGHTS;
        for (int i = 0; i < VX_MAX_LIGHTS; i++) {
            q->to_light[i] = direction(angles[i % ANGLES].c, i % 2 ? 90 : 180);
            q->irradiance[i] = E;
        }
        snprintf(desc, desc_size, "%d lights", VX_MAX_LIGHTS);
    }
}

/* ---------- checks ---------- */

typedef struct {
    int bad;
    char why[768];
    const char *geometry; /* the voxel geometry being run, for the message */
    int geometry_bad;     /* the current geometry has failed */
    char geometries[256]; /* every geometry that failed */
} verdict;

static void fail(verdict *v, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void fail(verdict *v, const char *fmt, ...)
{
    if (!v->geometry_bad++) {
        size_t len = strlen(v->geometries);
        snprintf(v->geometries + len, sizeof v->geometries - len, "%s%s", len ? ", " : "", v->geometry);
    }
    if (v->bad++)
        return; /* the first failure explains; the rest only count */
    va_list ap;
    va_start(ap, fmt);
    int n = snprintf(v->why, sizeof v->why, "[%s voxel] ", v->geometry);
    vsnprintf(v->why + n, sizeof v->why - (size_t)n, fmt, ap);
    va_end(ap);
}

static int finite3(vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

/* The checks every answer must pass. */
static void check_answer(const vx_model *m, const sample_summary *sum, const vx_query *q, float opacity,
                         const vx_answer *a, const char *where, verdict *v)
{
    if (!isfinite(opacity) || opacity < 0.0f || opacity > 1.0f) {
        fail(v, "%s: opacity %g outside [0, 1]", where, (double)opacity);
        return;
    }
    if (!finite3(a->radiance) || a->radiance.x < 0 || a->radiance.y < 0 || a->radiance.z < 0) {
        fail(v, "%s: radiance (%g, %g, %g) not finite and >= 0", where, (double)a->radiance.x,
             (double)a->radiance.y, (double)a->radiance.z);
        return;
    }
    double bound = 0;
    for (int i = 0; i < q->light_count; i++) {
        vec3 E = q->irradiance[i];
        double e = fmax(E.x, fmax(E.y, E.z));
        bound += e * (2.0 * sum->albedo_max / M_PI +
                      ((q->effects & VX_EFFECT_SPECULAR) ? 2.0 * sum->f0_max * sum->spec_peak : 0.0));
    }
    /* Only voxels the tracer would shade (opacity > 0) carry a meaningful radiance. */
    double rmax = fmax(a->radiance.x, fmax(a->radiance.y, a->radiance.z));
    if (opacity > 0.0f && rmax > bound * (1.0 + 1e-5) + 1e-30) {
        fail(v, "%s: radiance %g above the bound %g (albedo max %g, f0 max %g, D*G/(4 n.v) peak %g)", where,
             rmax, bound, sum->albedo_max, sum->f0_max, sum->spec_peak);
        return;
    }
    if (vx_model_compositing(m) == VX_COMPOSITE_COVERAGE && !(opacity > 0.0f))
        for (int w = 0; w < VX_MASK_WORDS; w++)
            if (a->mask[w]) {
                fail(v, "%s: opacity 0 but coverage mask word %d = %08x", where, w, a->mask[w]);
                return;
            }
}

/* Model-specific facts (from the models' own documented definitions). */
static void check_baseline(const vx_model *m, const bake_case *c, const sample_summary *sum, float opacity,
                           const char *where, verdict *v)
{
    if (c->expect == EXPECT_EMPTY && (!strcmp(m->name, "binary") || !strcmp(m->name, "alpha")) && opacity != 0.0f)
        fail(v, "%s: empty voxel, opacity %g (want 0)", where, (double)opacity);
    if (c->expect == EXPECT_FULL && (!strcmp(m->name, "binary") || !strcmp(m->name, "alpha")) && opacity != 1.0f)
        fail(v, "%s: every sample hit inside, opacity %.9g (want 1)", where, (double)opacity);
    if (!strcmp(m->name, "alpha")) {
        /* Brito et al. §3.2: cases (a) and (b) occlude, a miss does not; a voxel without a front-facing
         * hit is transparent, as vmesh's sub-cells are (models/alpha/alpha.c). */
        double want = sum->n && sum->front > 0 ? (double)sum->occluding / (double)sum->n : 0.0;
        if (fabs(opacity - want) > 1e-6 * fmax(1.0, want))
            fail(v, "%s: alpha opacity %.9g, want the occluding (INSIDE + OUTSIDE) fraction %d/%d = %.9g (%d front hits)",
                 where, (double)opacity, sum->occluding, sum->n, want, sum->front);
    }
    if (!strcmp(m->name, "binary")) {
        float want = sum->front > 0 ? 1.0f : 0.0f;
        if (opacity != want)
            fail(v, "%s: binary opacity %g, want %g (%d front hits)", where, (double)opacity, (double)want, sum->front);
    }
}

/* Runs every query against one baked record (or, for cone-marching models, one grid of records). */
static void query_all(const vx_model *m, const bake_case *c, const sample_summary *sum, const void *record,
                      const geometry *geo, const voxel_grid *g, const void *records, verdict *v)
{
    double size = geo ? geo->size : g->voxel_size_d;
    vec3 lo = geo ? v3((float)geo->lo[0], (float)geo->lo[1], (float)geo->lo[2]) : g->origin;
    if (!geo) { /* the grid's first voxel */
        int x, y, z;
        vec3 hi;
        grid_coords(g, 0, 0, &x, &y, &z);
        grid_cell_corners(g, 0, x, y, z, &lo, &hi);
    }
    double centre[3] = {lo.x + 0.5 * size, lo.y + 0.5 * size, lo.z + 0.5 * size};
    char where[512], ldesc[96];
    for (int vi = 0; vi < ANGLES; vi++)
        for (int ls = 0; ls < LIGHT_SETS; ls++)
            for (size_t ii = 0; ii < sizeof irradiances / sizeof irradiances[0]; ii++)
                for (size_t ei = 0; ei < sizeof effect_sets / sizeof effect_sets[0]; ei++)
                    for (size_t fi = 0; fi < sizeof footprints / sizeof footprints[0]; fi++) {
                        vx_query q;
                        memset(&q, 0, sizeof q);
                        q.to_viewer = direction(angles[vi].c, 0);
                        q.ray_dir = v3_scale(q.to_viewer, -1.0f);
                        double back_off = 4.0 * size;
                        q.ray_origin = v3((float)(centre[0] + back_off * q.to_viewer.x),
                                          (float)(centre[1] + back_off * q.to_viewer.y),
                                          (float)(centre[2] + back_off * q.to_viewer.z));
                        double amax = fmax(fabs(q.ray_dir.x), fmax(fabs(q.ray_dir.y), fabs(q.ray_dir.z)));
                        q.t0 = (float)(back_off - 0.5 * size / amax);
                        q.t1 = (float)(back_off + 0.5 * size / amax);
                        q.voxel_lo = lo;
                        q.voxel_size = (float)size;
                        q.footprint = (float)(footprints[fi] * size);
                        q.effects = effect_sets[ei];
                        set_lights(&q, ls, irradiances[ii].value, ldesc, sizeof ldesc);
                        snprintf(where, sizeof where, "view %s deg, %s, %s, effects %u, footprint %g",
                                 angles[vi].name, ldesc, irradiances[ii].name, q.effects, (double)q.footprint);
                        vx_answer a;
                        memset(&a, 0, sizeof a);
                        if (g) { /* cone marching: levels 0, 0.5 and the top */
                            q.grid = g;
                            q.records = records;
                            size_t table_bytes;
                            q.table = m->cone->table ? m->cone->table(&table_bytes) : NULL;
                            q.position = v3((float)centre[0], (float)centre[1], (float)centre[2]);
                            const float levels[3] = {0.0f, 0.5f, (float)(g->levels - 1)};
                            for (int l = 0; l < 3; l++) {
                                q.level = levels[l];
                                memset(&a, 0, sizeof a);
                                m->cone->element.fn(&q, &a);
                                check_answer(m, sum, &q, a.opacity, &a, where, v);
                            }
                            continue;
                        }
                        float op = m->voxel->opacity.fn(record, &q);
                        a.opacity = op;
                        m->voxel->shade.fn(record, &q, &a);
                        check_answer(m, sum, &q, op, &a, where, v);
                        check_baseline(m, c, sum, op, where, v);
                    }
}

/* A small grid (one triangle at 4^3) whose every level-0 record is baked from the case's samples,
 * for models that need bake_finish or cone marching. */
static void *bake_grid(const vx_model *m, const vx_sample *samples, int n, voxel_grid *g)
{
    mesh me;
    memset(&me, 0, sizeof me);
    mesh_add_flat_triangle(&me, v3(0.1f, 0.2f, 0.3f), v3(1.0f, 0.25f, 0.35f), v3(0.3f, 0.9f, 0.7f), 0);
    vx_err e;
    if (grid_build(g, &me, 4, &e)) {
        printf("not ok grid for bake_finish: %s\n", e.msg);
        mesh_free(&me);
        return NULL;
    }
    mesh_free(&me);
    size_t count = bake_record_count(m, g);
    struct vx_bake_params defaults;
    bake_params_defaults(m, &defaults);
    unsigned char *rec = calloc(count ? count : 1, m->record.bytes);
    for (size_t i = 0; i < grid_count(g, 0); i++) {
        vx_voxel vv;
        vec3 hi;
        grid_coords(g, 0, i, &vv.x, &vv.y, &vv.z);
        grid_cell_corners(g, 0, vv.x, vv.y, vv.z, &vv.lo, &hi);
        vv.index = (long long)i;
        vv.size = g->voxel_size;
        vv.effects = VX_EFFECT_SPECULAR | VX_EFFECT_SHADOWS;
        vv.params = &defaults;
        m->bake_voxel(&vv, samples, n, rec + i * m->record.bytes);
    }
    if (m->bake_finish && m->bake_finish(g, rec, &defaults) != 0) {
        free(rec);
        grid_free(g);
        return NULL;
    }
    return rec;
}

enum { GUARD = 64 };

static void run_geometry(const vx_model *m, const bake_case *c, const geometry *geo, uint64_t seed, verdict *vp)
{
    vp->geometry = geo->name;
    vp->geometry_bad = 0;
    vx_sample *samples = calloc((size_t)c->n + 1, sizeof *samples);
    make_samples(c, geo, seed, samples);
    /* Zero samples: the array holds one NaN-filled sample, so a model that reads samples[0] anyway
     * shows up as a non-finite answer rather than as luck. */
    if (c->n == 0)
        memset(samples, 0xff, sizeof *samples);
    sample_summary sum;
    summarise(samples, c->n, &sum);

    vx_voxel vv = {.x = 5, .y = 6, .z = 7, .index = 42,
                   .lo = v3((float)geo->lo[0], (float)geo->lo[1], (float)geo->lo[2]),
                   .size = (float)geo->size, .effects = VX_EFFECT_SPECULAR | VX_EFFECT_SHADOWS};
    /* The record is zeroed (the interface's promise) and followed by a guard the bake must not touch. */
    unsigned char *rec = calloc(1, m->record.bytes + GUARD), *rec2 = calloc(1, m->record.bytes + GUARD);
    memset(rec + m->record.bytes, 0xa5, GUARD);
    m->bake_voxel(&vv, samples, c->n, rec);
    m->bake_voxel(&vv, samples, c->n, rec2);
    for (int i = 0; i < GUARD; i++)
        if (rec[m->record.bytes + (size_t)i] != 0xa5) {
            fail(vp, "bake_voxel wrote past voxel_bytes (%zu) at byte +%d", m->record.bytes, i);
            break;
        }
    if (memcmp(rec, rec2, m->record.bytes) != 0)
        fail(vp, "baking the same samples twice gave different records");
    /* What the bake writes must be what the model says a record may hold: otherwise a genuine .vox
     * file would be refused on load (tracer/bake/record_check.c). */
    if (m->validate_record) {
        vx_record_context rctx = {.level = 0, .cell_size = (float)geo->size, .rays = c->n};
        char why[256] = "";
        if (m->validate_record(rec, &rctx, why, sizeof why) != 0)
            fail(vp, "its own bake's record fails validate_record: %s", why);
    }
    unsigned char *copy = malloc(m->record.bytes);
    memcpy(copy, rec, m->record.bytes);

    /* Voxel-evaluation models answer per voxel (cone-evaluation ones below, on a grid). */
    if (m->voxel)
        query_all(m, c, &sum, rec, geo, NULL, NULL, vp);
    if (memcmp(copy, rec, m->record.bytes) != 0)
        fail(vp, "opacity/shade modified the record");
    /* Moving records (issue 17): the identity leaves the record bit for bit, and a record turned by
     * a quarter turn, by an oblique rotation, or merged from two halves of itself answers every
     * query within the same bounds as a baked one. */
    if (m->transform && m->voxel) {
        static const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, Rz[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
        const float co = 0.8f, s6 = 0.6f, Ro[9] = {co, 0, s6, 0, 1, 0, -s6, 0, co}; /* about y, 36.87 degrees */
        unsigned char *moved = calloc(1, m->record.bytes), *merged = calloc(1, m->record.bytes);
        m->transform(rec, I, moved);
        if (memcmp(moved, rec, m->record.bytes) != 0)
            fail(vp, "transform by the identity changed the record");
        const float *turns[2] = {Rz, Ro};
        for (int k = 0; k < 2; k++) {
            m->transform(rec, turns[k], moved);
            query_all(m, c, &sum, moved, geo, NULL, NULL, vp);
        }
        const vx_record_part whole[1] = {{rec, 1.0f, {0, 0, 0}}}, halves[2] = {{rec, 0.5f, {0, 0, 0}}, {rec, 0.5f, {0, 0, 0}}};
        m->combine(whole, 1, 1.0f, merged);
        if (memcmp(merged, rec, m->record.bytes) != 0)
            fail(vp, "combine of one record with weight 1 changed it");
        m->combine(halves, 2, 1.0f, merged);
        query_all(m, c, &sum, merged, geo, NULL, NULL, vp);
        free(moved);
        free(merged);
    }
    /* Models with a grid pass or cone marching: the same samples in every voxel of a small grid,
     * answers looked up after bake_finish (only once per case: the grid has its own geometry). */
    if ((m->bake_finish || m->cone != NULL) && geo == &geometries[0]) {
        voxel_grid g;
        void *records = bake_grid(m, samples, c->n, &g);
        if (!records)
            fail(vp, "bake_finish failed on a 4^3 grid");
        else {
            const void *rec0 = records; /* level 0, voxel 0 */
            if (m->cone != NULL)
                query_all(m, c, &sum, NULL, NULL, &g, records, vp);
            else
                query_all(m, c, &sum, rec0, geo, NULL, NULL, vp);
            /* Moving records of a model with levels (issue 17): every level-0 record turned
             * obliquely and merged from two halves of itself off the cell's centre, the levels
             * rebuilt by bake_finish, answers within the same bounds. */
            if (m->transform && m->record.levels) {
                static const float Ro[9] = {0.8f, 0, 0.6f, 0, 1, 0, -0.6f, 0, 0.8f};
                size_t bytes = m->record.bytes;
                unsigned char *turned = malloc(bytes), *moved = calloc(bake_record_count(m, &g), bytes);
                struct vx_bake_params defaults;
                bake_params_defaults(m, &defaults);
                for (size_t i = 0; i < grid_count(&g, 0); i++) {
                    m->transform((const char *)records + i * bytes, Ro, turned);
                    const vx_record_part halves[2] = {{turned, 0.5f, {0.3f, -0.2f, 0.1f}}, {turned, 0.5f, {-0.3f, 0.2f, -0.1f}}};
                    m->combine(halves, 2, g.voxel_size, moved + i * bytes);
                }
                if (m->bake_finish(&g, moved, &defaults))
                    fail(vp, "bake_finish failed on moved records");
                else
                    query_all(m, c, &sum, NULL, NULL, &g, moved, vp);
                free(turned);
                free(moved);
            }
            free(records);
            grid_free(&g);
        }
    }
    free(copy);
    free(rec);
    free(rec2);
    free(samples);
}

/* One case through one model, at every voxel geometry: one protocol line. */
static void run_case(const vx_model *m, const bake_case *c, uint64_t seed)
{
    verdict v;
    memset(&v, 0, sizeof v);
    for (size_t gi = 0; gi < sizeof geometries / sizeof geometries[0]; gi++)
        run_geometry(m, c, &geometries[gi], seed, &v);
    if (v.bad)
        printf("not ok %s / %s: %s (%d failed answers; failing voxels: %s)\n", m->name, c->name, v.why, v.bad,
               v.geometries);
    else
        printf("ok %s / %s\n", m->name, c->name);
    unit_failures += v.bad > 0;
}

/* ---------- the registry ---------- */

static void check_registry(void)
{
    const vx_model *const *all = model_all();
    int count = 0, have_binary = 0, have_alpha = 0;
    for (const vx_model *const *p = all; *p; p++) {
        const vx_model *m = *p;
        char name[160];
        count++;
        have_binary |= m->name && !strcmp(m->name, "binary");
        have_alpha |= m->name && !strcmp(m->name, "alpha");
        snprintf(name, sizeof name, "registry: %s: name and description", m->name ? m->name : "(null)");
        /* The name is stored in a .vox header's model[32], NUL-terminated. */
        CHECK(name, m->name && m->name[0] && strlen(m->name) < sizeof(((voxfile_header *)0)->model) &&
                        m->description && m->description[0]);
        snprintf(name, sizeof name, "registry: %s: model_find finds it", m->name);
        CHECK(name, model_find(m->name) == m);
        snprintf(name, sizeof name, "registry: %s: unique name", m->name);
        int same = 0;
        for (const vx_model *const *q = all; *q; q++)
            same += (*q)->name && !strcmp((*q)->name, m->name);
        CHECK(name, same == 1);
        char why[256] = "";
        snprintf(name, sizeof name, "registry: %s: keeps the model interface's rules (model_check)", m->name);
        int rc = model_check(m, why, sizeof why);
        CHECK(name, rc == 0);
        if (rc)
            printf("#   %s\n", why);
        snprintf(name, sizeof name, "registry: %s: levels are filled by bake_finish", m->name);
        CHECK(name, !m->record.levels || m->bake_finish);
    }
    CHECK("registry: binary and alpha registered", have_binary && have_alpha && count >= 2);
    CHECK("registry: unknown name gives NULL", model_find("no-such-model") == NULL && model_find("") == NULL);
}

/* model_check refuses each broken rule of the interface (a copy of a registered model, one field
 * broken at a time), and the parameters' parsing refuses what it must. */
static const vx_param test_params[] = {
    {"k", 0.5, 0.0, 1.0, "a test knob", 0}, {"n", 3, 1, 8, "another", 0}, {"s", 0, 0, 1, "a switch", 1}, {0}};
static const vx_param bad_default[] = {{"k", 2.0, 0.0, 1.0, "default outside its range", 0}, {0}};
static const vx_param bad_switch[] = {{"s", 0, 0, 2, "a switch with three settings", 1}, {0}};

static void check_interface_rules(void)
{
    const vx_model *binary = model_find("binary"), *hn = model_find("heitz-neyret");
    char why[256];
    vx_model m = *binary;
    CHECK("model_check: binary as registered passes", model_check(&m, why, sizeof why) == 0);
    m.abi_version = VX_MODEL_ABI_VERSION + 1;
    CHECK("model_check: another ABI version is refused",
          model_check(&m, why, sizeof why) && strstr(why, "abi_version"));
    m = *binary;
    m.cone = hn->cone;
    CHECK("model_check: two protocols are refused", model_check(&m, why, sizeof why) && strstr(why, "exactly one"));
    m = *binary;
    m.voxel = NULL;
    CHECK("model_check: no protocol is refused", model_check(&m, why, sizeof why) && strstr(why, "exactly one"));
    vx_voxel_eval ve = *binary->voxel;
    m = *binary;
    m.voxel = &ve;
    ve.compositing = VX_COMPOSITE_COVERAGE;
    CHECK("model_check: voxel evaluation with coverage compositing is refused",
          model_check(&m, why, sizeof why) && strstr(why, "first hit or alpha"));
    ve = *binary->voxel;
    ve.view_tile_pixels = VX_VIEW_TILE_MAX_PIXELS;
    int widest_ok = model_check(&m, why, sizeof why) == 0;
    ve.view_tile_pixels = VX_VIEW_TILE_MAX_PIXELS + 1;
    int wider_refused = model_check(&m, why, sizeof why) && strstr(why, "view_tile_pixels");
    ve.view_tile_pixels = -1;
    CHECK("model_check: view tiles of 0 to VX_VIEW_TILE_MAX_PIXELS pass, wider or negative ones are refused",
          widest_ok && wider_refused && model_check(&m, why, sizeof why) && strstr(why, "view_tile_pixels"));
    ve = *binary->voxel;
    ve.shade.name = "binary eval shade";
    CHECK("model_check: a portable name that is not an identifier is refused",
          model_check(&m, why, sizeof why) && strstr(why, "VX_PORTABLE"));
    m = *hn;
    m.record.levels = 0;
    CHECK("model_check: cone evaluation without levels is refused",
          model_check(&m, why, sizeof why) && strstr(why, "levels"));
    m = *binary;
    m.record.layout_version = 0;
    CHECK("model_check: a missing layout version is refused", model_check(&m, why, sizeof why) != 0);
    m.record.layout_version = 1;
    m.params = bad_default;
    CHECK("model_check: a parameter's default outside its range is refused",
          model_check(&m, why, sizeof why) && strstr(why, "default"));
    m.params = bad_switch;
    CHECK("model_check: a switch whose range is not [0, 1] is refused",
          model_check(&m, why, sizeof why) && strstr(why, "switch"));
    m.params = test_params;
    CHECK("model_check: parameters with defaults in range pass", model_check(&m, why, sizeof why) == 0);

    struct vx_bake_params p;
    vx_err e;
    bake_params_defaults(&m, &p);
    CHECK("params: defaults", p.value[0] == 0.5 && p.value[1] == 3);
    CHECK("params: name=value sets it", bake_params_assign(&m, "n=5", &p, &e) == 0 && p.value[1] == 5);
    CHECK("params: an unknown name is refused, naming the known ones",
          bake_params_assign(&m, "q=1", &p, &e) && strstr(e.msg, "no parameter \"q\"") && strstr(e.msg, "k, n"));
    CHECK("params: a value out of range is refused with the range",
          bake_params_assign(&m, "k=1.5", &p, &e) && strstr(e.msg, "[0, 1]"));
    CHECK("params: a value that is not a number is refused", bake_params_assign(&m, "k=abc", &p, &e) != 0);
    /* A switch is 0 or 1: 0.5 is in its range, but the model reads it as one side (> 0.5) while the
     * .vox and --stats would say 0.5. */
    CHECK("params: a switch between 0 and 1 is refused",
          bake_params_assign(&m, "s=0.5", &p, &e) && strstr(e.msg, "s is a switch: expected 0 or 1"));
    CHECK("params: a switch takes 1 and 0", bake_params_assign(&m, "s=1", &p, &e) == 0 && p.value[2] == 1 &&
                                                bake_params_assign(&m, "s=0", &p, &e) == 0 && p.value[2] == 0);
    CHECK("params: vicini's extended is declared a switch",
          model_find("vicini") && !strcmp(model_find("vicini")->params[0].name, "extended") &&
              model_find("vicini")->params[0].is_switch);
    CHECK("params: no '=' is refused", bake_params_assign(&m, "k", &p, &e) && strstr(e.msg, "name=value"));
    CHECK("params: a model without parameters refuses any", bake_params_assign(binary, "k=1", &p, &e) &&
                                                                 strstr(e.msg, "(its parameters: none)"));
    char text[256];
    struct vx_bake_params back;
    bake_params_assign(&m, "k=0.1", &p, &e);
    CHECK("params: formatted text reads back exactly",
          bake_params_format(&m, &p, text, sizeof text) == 0 && !strcmp(text, "k=0.10000000000000001,n=5,s=0") &&
              bake_params_parse(&m, text, &back, &e) == 0 && back.value[0] == p.value[0] && back.value[1] == 5);
    CHECK("params: heitz-neyret declares edge_clear",
          hn->params && !strcmp(hn->params[0].name, "edge_clear") && hn->params[0].fallback == 0.4);
}

/* The bound itself must be right, or the table proves nothing: G_sup and D_max against hand values. */
static void check_bound_helpers(void)
{
    CHECK_NEAR("bound: Beckmann peak 1/(pi a^2) at a = 0.3", beckmann_max(0.3), 1.0 / (M_PI * 0.09), 1e-9);
    /* Lambda -> sigma / (c sqrt(2 pi)) - 1/2 at grazing angles, so 1/(4c(1 + Lambda)) rises to
     * sqrt(2 pi) / (4 sigma) as c -> 0 (about 1/(4c) while c >> sigma): that limit is the supremum. */
    for (int i = 0; i < 2; i++) {
        double alpha = i ? 1e-4 : 0.3, sigma = alpha / M_SQRT2, limit = sqrt(2 * M_PI) / (4 * sigma);
        char name[96];
        snprintf(name, sizeof name, "bound: G_sup = sqrt(2 pi) / (4 sigma) at alpha = %g", alpha);
        CHECK_NEAR(name, g_over_nv_sup(alpha) / limit, 1.0, 0.01);
    }
}

int main(void)
{
    check_registry();
    check_interface_rules();
    check_bound_helpers();
    for (const vx_model *const *p = model_all(); *p; p++)
        for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++)
            run_case(*p, &cases[c], 1000 + c);
    return unit_exit();
}
