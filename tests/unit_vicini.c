/* The vicini model (models/vicini/) against independent references:
 *  - f^-1 against bisection in double;
 *  - the heterogeneous transmittance of voxel sequences against a numerical integration of the
 *    model's differential form (RK4 in double, with the equivalent depth found by bisection), and
 *    the exponential case against Beer-Lambert;
 *  - the maximum-likelihood estimator on synthetic free flights of known density and mix (drawn
 *    here by inverting the transmittance), and the likelihood at the estimate against the truth's;
 *  - the bake on synthetic voxels: a plate comes out linear, a cloud of leaves exponential, a solid
 *    voxel opaque from every direction, an empty one clear;
 *  - the shading of a plate against Lambert, and the record's size (11 bytes, Brito et al. §5);
 *  - the C build's SSE phase function against the scalar definition, bit for bit. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake_params.h"
#include "model.h"
#include "rng.h"
#include "unit.h"
#include "vicini_eval.h"
#include "vicini_fit.h"

extern const vx_model model_vicini;

/* ---------- independent references ---------- */

static double f_ref(double tau, double gamma)
{
    return gamma * exp(-tau) + (1.0 - gamma) * fmax(1.0 - 0.5 * tau, 0.0);
}

/* The smallest tau with f(tau) <= y, by bisection (f is non-increasing). */
static double f_inv_ref(double y, double gamma)
{
    if (y >= 1.0)
        return 0.0;
    double lo = 0.0, hi = 200.0;
    for (int i = 0; i < 200; i++) {
        double m = 0.5 * (lo + hi);
        if (f_ref(m, gamma) > y)
            lo = m;
        else
            hi = m;
    }
    return hi;
}

/* dT/ds inside a voxel of mix gamma, s its optical depth: the slope of f at T's equivalent depth. */
static double slope_ref(double T, double gamma)
{
    double u = f_inv_ref(T, gamma);
    return -(gamma * exp(-u) + (u < 2.0 ? 0.5 * (1.0 - gamma) : 0.0));
}

/* Transmittance after the voxels (tau[k], gamma[k]): RK4 on dT/ds, 400 steps per voxel. */
static double chain_ref(const double *tau, const double *gamma, int n)
{
    double T = 1.0;
    for (int k = 0; k < n; k++) {
        int steps = 400;
        double h = tau[k] / steps;
        for (int i = 0; i < steps && T > 1e-12; i++) {
            double k1 = slope_ref(T, gamma[k]), k2 = slope_ref(fmax(T + 0.5 * h * k1, 0.0), gamma[k]);
            double k3 = slope_ref(fmax(T + 0.5 * h * k2, 0.0), gamma[k]), k4 = slope_ref(fmax(T + h * k3, 0.0), gamma[k]);
            T = fmax(T + h * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0, 0.0);
        }
    }
    return T;
}

/* ---------- f^-1 and the heterogeneous model ---------- */

static void test_inverse(void)
{
    const double gammas[] = {0.0, 0.05, 0.3, 0.7, 1.0};
    double worst = 0.0;
    for (int g = 0; g < 5; g++)
        for (int i = 0; i <= 200; i++) {
            double y = i / 200.0;
            if (y == 0.0 && gammas[g] > 0.0)
                continue; /* infinite depth */
            double got = vicini_f_inv((float)y, (float)gammas[g]), want = f_inv_ref(y, gammas[g]);
            worst = fmax(worst, fabs(got - want) / fmax(1.0, want));
        }
    CHECK_NEAR("f^-1 equals bisection in double (5 mixes x 201 values)", worst, 0.0, 2e-5);
    CHECK("f^-1(0) is a depth that transmits nothing", vicini_f(vicini_f_inv(0.0f, 0.5f), 0.5f) < 1e-30f);
}

/* The remembered inverse (the C build's per-thread table) gives vicini_f_inv's bits for every
 * argument, asked once or again, after its entry was taken by another key (the table has 1024
 * entries; 60000 keys collide), for the edge cases too (0, 1, above 1, negative, NaN, the mix 0). */
static void test_inverse_remembered(void)
{
    rng g = rng_seed(23, 0);
    enum { KEYS = 60000 };
    static float ys[KEYS], gs[KEYS];
    const float edges[] = {0.0f, -0.0f, 1.0f, 1.5f, -0.25f, NAN, 0.13533528f, 1e-30f, 0.999999f};
    for (int k = 0; k < KEYS; k++) {
        ys[k] = k < 9 ? edges[k] : (k % 7 == 0 ? (float)(k % 50) / 49.0f : rng_float(&g));
        gs[k] = k % 5 == 0 ? 0.0f : (k % 11 == 0 ? NAN : (float)(k % 13) / 12.0f);
    }
    int bad = 0, asked = 0;
    for (int pass = 0; pass < 3; pass++)
        for (int k = 0; k < KEYS; k++) {
            /* pass 1 asks in order (repeats after collisions), pass 2 asks each key twice in a row */
            int reps = pass == 2 ? 2 : 1;
            for (int r = 0; r < reps; r++) {
                float want = vicini_f_inv(ys[k], gs[k]), got = vicini_f_inv_remembered(ys[k], gs[k]);
                bad += memcmp(&want, &got, sizeof want) != 0;
                asked++;
            }
        }
    char name[160];
    snprintf(name, sizeof name, "remembered f^-1 gives f^-1's bits (%d asks of %d keys, %d differ)", asked, KEYS,
             bad);
    CHECK(name, bad == 0);
}

/* f without its expf where the mix is linear (gamma 0, tau >= 0) gives the bits of the formula with
 * the call, for either zero's sign and the edge depths too (0, -0, 2, huge, infinite, negative,
 * NaN: the last two still call it), and for mixed gammas as before. */
static void test_linear_mix_without_exp(void)
{
    rng g = rng_seed(29, 0);
    const float edges[] = {0.0f, -0.0f, 2.0f, 1.9999999f, 1e-30f, 1e30f, INFINITY, -INFINITY, -0.5f, NAN, 104.0f};
    const float gammas[] = {0.0f, -0.0f, 1e-30f, 0.5f, 1.0f};
    int bad = 0, asked = 0;
    for (int k = 0; k < 20000; k++) {
        float tau = k < 11 ? edges[k] : (k % 3 == 0 ? 4.0f * rng_float(&g) : 200.0f * rng_float(&g));
        for (int j = 0; j < 5; j++) {
            float want = vicini_f_with_exp(expf(-tau), tau, gammas[j]), got = vicini_f(tau, gammas[j]);
            bad += memcmp(&want, &got, sizeof want) != 0;
            asked++;
        }
    }
    char name[160];
    snprintf(name, sizeof name, "f skips expf for a linear mix with the same bits (%d depths and mixes, %d differ)",
             asked, bad);
    CHECK(name, bad == 0);
}

static void test_heterogeneous(void)
{
    rng r = rng_seed(7, 0);
    double worst = 0.0;
    for (int seq = 0; seq < 12; seq++) {
        double tau[6], gamma[6];
        int n = 2 + seq % 5;
        float T = 1.0f;
        for (int k = 0; k < n; k++) {
            tau[k] = 1.5 * rng_float(&r);
            gamma[k] = seq % 3 == 0 ? (double)(k % 2) : rng_float(&r); /* alternate pure mixes too */
            T = vicini_step(T, (float)tau[k], (float)gamma[k]);
        }
        worst = fmax(worst, fabs((double)T - chain_ref(tau, gamma, n)));
    }
    CHECK_NEAR("heterogeneous transmittance of 12 voxel sequences equals RK4 on the model's ODE", worst, 0.0, 2e-4);

    /* Exponential voxels are Beer-Lambert; one voxel cut into ten is the same voxel. */
    float T = 1.0f;
    double sum = 0.0;
    for (int k = 0; k < 5; k++) {
        T = vicini_step(T, 0.3f * (float)(k + 1), 1.0f);
        sum += 0.3 * (k + 1);
    }
    CHECK_NEAR("gamma = 1 chains to exp(-sum tau)", T, exp(-sum), 1e-6);
    for (int g = 0; g <= 4; g++) {
        float gamma = 0.25f * (float)g, whole = vicini_f(1.3f, gamma), cut = 1.0f;
        for (int k = 0; k < 10; k++)
            cut = vicini_step(cut, 0.13f, gamma);
        char name[96];
        snprintf(name, sizeof name, "a voxel cut into ten is the same voxel (gamma %.2f)", (double)gamma);
        CHECK_NEAR(name, cut, whole, 2e-5);
    }
    /* transmit() from the standalone opacity is the step from T. */
    vicini_record rec = {{255, 255, 255}, {127, 127, 127}, 200, 40, {100, 100, 100}};
    vx_query q = {0};
    q.ray_dir = v3_normalize(v3(0.3f, -0.5f, 0.8f));
    float a = vicini_eval_opacity(&rec, &q);
    CHECK_NEAR("transmit from T = 1 is 1 - opacity", vicini_eval_transmit(&rec, a, 1.0f), 1.0f - a, 1e-6);
    CHECK("transmit never brightens", vicini_eval_transmit(&rec, a, 0.4f) <= 0.4f);
}

/* ---------- the estimator ---------- */

/* n flights of known (rho, gamma): a collision depth drawn by inverting f, a path available of
 * 0.3..3.5 optical depths (over thin paths both laws start as 1 - c tau and the mix is barely
 * identifiable: what separates them is how the transmittance ends). */
static void synth(vicini_flight *f, int n, double rho, double gamma, uint64_t seed)
{
    rng r = rng_seed(seed, 1);
    for (int i = 0; i < n; i++) {
        double avail = (0.3 + 3.2 * rng_float(&r)) / rho;
        double u = fmax(rng_float(&r), 1e-7);
        double x = f_inv_ref(u, gamma) / rho;
        f[i].collided = x < avail;
        f[i].x = (float)(x < avail ? x : avail);
    }
}

static void test_estimator(void)
{
    const struct {
        double rho, gamma;
    } cases[] = {{3.0, 0.0}, {3.0, 1.0}, {1.5, 0.5}, {0.6, 1.0}, {4.0, 0.2}, {2.0, 0.8}};
    enum { N = 6000 };
    vicini_flight *f = malloc(N * sizeof *f);
    double densities[255];
    for (int k = 0; k < 255; k++)
        densities[k] = vicini_decode_density((unsigned)k + 1u);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        synth(f, N, cases[c].rho, cases[c].gamma, 100 + c);
        vicini_estimate e;
        vicini_fit(f, N, densities, 255, &e);
        char name[128];
        snprintf(name, sizeof name, "estimator recovers gamma %.1f (rho %.1f, %d flights)", cases[c].gamma,
                 cases[c].rho, N);
        CHECK_NEAR(name, e.gamma, cases[c].gamma, 0.08);
        snprintf(name, sizeof name, "estimator recovers rho %.1f (gamma %.1f): relative error", cases[c].rho,
                 cases[c].gamma);
        CHECK_NEAR(name, e.density / cases[c].rho, 1.0, 0.08);
        snprintf(name, sizeof name, "estimate's likelihood >= the truth's on the density codes (rho %.1f, gamma %.1f)", cases[c].rho,
                 cases[c].gamma);
        /* The estimate is the best among the storable densities: at least as likely as the truth's
         * neighbours on that grid (within the grid's step, the truth itself may do better). */
        double step = exp2(VICINI_DENSITY_LOG2_RANGE / 254.0), truth_ll = -INFINITY;
        for (int k = 0; k < 255; k++)
            if (densities[k] > cases[c].rho / step && densities[k] < cases[c].rho * step)
                truth_ll = fmax(truth_ll, vicini_log_likelihood(f, N, densities[k], cases[c].gamma));
        CHECK(name, e.log_likelihood >= truth_ll - 1e-6);
    }
    for (int i = 0; i < 50; i++)
        f[i].collided = 0, f[i].x = 0.5f;
    vicini_estimate e;
    vicini_fit(f, 50, densities, 255, &e);
    CHECK("no collision: density 0", e.density == 0.0);
    free(f);
}

/* ---------- the bake on synthetic voxels ---------- */

/* A ray through the unit voxel [0,1]^3: a uniform direction and an origin uniform over the
 * voxel's projection, 3 units back; returns 0 when the ray misses the box. */
static int unit_ray(rng *r, vx_sample *s)
{
    float z = 1.0f - 2.0f * rng_float(r), phi = 2.0f * VX_PI * rng_float(r), sz = sqrtf(fmaxf(0.0f, 1.0f - z * z));
    vec3 d = v3(sz * cosf(phi), sz * sinf(phi), z), t, b;
    v3_basis(d, &t, &b);
    vec3 c = v3(0.5f, 0.5f, 0.5f);
    float u = 1.8f * (rng_float(r) - 0.5f), v = 1.8f * (rng_float(r) - 0.5f);
    vec3 o = v3_add(v3_sub(c, v3_scale(d, 3.0f)), v3_add(v3_scale(t, u), v3_scale(b, v)));
    float t0 = -INFINITY, t1 = INFINITY;
    for (int k = 0; k < 3; k++) {
        float ok = v3_get(o, k), dk = v3_get(d, k);
        if (fabsf(dk) < 1e-9f) {
            if (ok < 0.0f || ok > 1.0f)
                return 0;
            continue;
        }
        float a = (0.0f - ok) / dk, bb = (1.0f - ok) / dk;
        t0 = fmaxf(t0, fminf(a, bb));
        t1 = fminf(t1, fmaxf(a, bb));
    }
    if (!(t1 > t0))
        return 0;
    memset(s, 0, sizeof *s);
    s->origin = o, s->dir = d, s->t_entry = t0, s->t_exit = t1, s->t_hit = INFINITY;
    s->kind = VX_SAMPLE_MISS;
    return 1;
}

static void front_hit(vx_sample *s, float t, vec3 n)
{
    s->t_hit = t;
    s->kind = VX_SAMPLE_INSIDE_FRONT;
    s->normal = v3_dot(n, s->dir) < 0.0f ? n : v3_scale(n, -1.0f);
    s->albedo = v3(0.6f, 0.5f, 0.4f);
    s->roughness = 0.3f;
}

enum { PLATE, LEAVES, SOLID, EMPTY };

static int voxel_samples(int kind, vx_sample *out, int n)
{
    rng r = rng_seed(11 + (uint64_t)kind, 2);
    int m = 0;
    while (m < n) {
        vx_sample s;
        if (!unit_ray(&r, &s))
            continue;
        if (kind == PLATE) { /* the plane z = 0.5, extending beyond the voxel */
            float t = (0.5f - s.origin.z) / s.dir.z;
            if (fabsf(s.dir.z) > 1e-6f && t > 0.0f) {
                if (t >= s.t_entry && t <= s.t_exit)
                    front_hit(&s, t, v3(0, 0, 1));
                else
                    s.t_hit = t, s.kind = VX_SAMPLE_OUTSIDE;
            }
        } else if (kind == LEAVES) { /* small leaves scattered at random: exponential free flights */
            float d = -logf(fmaxf(rng_float(&r), 1e-7f)) / 2.5f;
            float nz = 1.0f - 2.0f * rng_float(&r), ph = 2.0f * VX_PI * rng_float(&r), ns = sqrtf(1.0f - nz * nz);
            if (s.t_entry + d <= s.t_exit)
                front_hit(&s, s.t_entry + d, v3(ns * cosf(ph), ns * sinf(ph), nz));
        } else if (kind == SOLID) { /* a block filling the voxel: every ray stops on entry */
            vec3 p = v3_add(s.origin, v3_scale(s.dir, s.t_entry));
            vec3 nrm = v3(0, 0, 0);
            float best = INFINITY;
            for (int k = 0; k < 3; k++) {
                float c = v3_get(p, k), dist = fminf(fabsf(c), fabsf(1.0f - c));
                if (dist < best) {
                    best = dist;
                    nrm = v3(k == 0, k == 1, k == 2);
                }
            }
            front_hit(&s, s.t_entry, nrm);
        }
        out[m++] = s;
    }
    return m;
}

static void bake(int kind, vicini_record *rec)
{
    enum { RAYS = 400 };
    vx_sample s[RAYS];
    voxel_samples(kind, s, RAYS);
    struct vx_bake_params p;
    bake_params_defaults(&model_vicini, &p);
    vx_voxel v = {.lo = v3(0, 0, 0), .size = 1.0f, .params = &p};
    memset(rec, 0, sizeof *rec);
    model_vicini.bake_voxel(&v, s, RAYS, rec);
}

static void test_bake(void)
{
    vicini_record rec;
    bake(PLATE, &rec);
    CHECK("a plate's voxel is near-linear (gamma <= 0.2)", vicini_decode_gamma(rec.mix) <= 0.2f);
    vx_query q = {0};
    q.ray_dir = v3(0, 0, -1);
    float face_on = vicini_eval_opacity(&rec, &q);
    q.ray_dir = v3_normalize(v3(1, 0, -0.02f));
    float edge_on = vicini_eval_opacity(&rec, &q);
    CHECK("a plate's voxel is opaque face-on (>= 0.95)", face_on >= 0.95f);
    CHECK("a plate's voxel is nearly clear edge-on (<= 0.35)", edge_on <= 0.35f);

    bake(LEAVES, &rec);
    CHECK("a leaf cloud's voxel is near-exponential (gamma >= 0.7)", vicini_decode_gamma(rec.mix) >= 0.7f);

    vicini_record solid, empty;
    bake(SOLID, &solid);
    bake(EMPTY, &empty);
    float lo_solid = 1.0f, hi_empty = 0.0f;
    for (int x = -1; x <= 1; x++)
        for (int y = -1; y <= 1; y++)
            for (int z = -1; z <= 1; z++) {
                if (!x && !y && !z)
                    continue;
                q.ray_dir = v3_normalize(v3((float)x, (float)y, (float)z));
                lo_solid = fminf(lo_solid, vicini_eval_opacity(&solid, &q));
                hi_empty = fmaxf(hi_empty, vicini_eval_opacity(&empty, &q));
            }
    CHECK_NEAR("a full voxel is opaque from all 26 directions", lo_solid, 1.0, 0.01);
    CHECK("an empty voxel is clear from all 26 directions (density code 0)", hi_empty == 0.0f && empty.density == 0);
}

/* ---------- shading ---------- */

static void test_shading(void)
{
    /* A plate (normal +z), white: per unit of removed transmittance, Lambert's E cos(theta_l) / pi. */
    vicini_record rec = {{3, 3, 255}, {127, 127, 127}, 255, 0, {255, 255, 255}};
    vx_query q = {0};
    q.light_count = 1;
    q.irradiance[0] = v3(1, 1, 1);
    double worst = 0.0;
    for (int i = 0; i < 4; i++) {
        float tl = 0.35f * (float)i, tv = 0.9f - 0.2f * (float)i;
        q.to_light[0] = v3(sinf(tl), 0, cosf(tl));
        q.to_viewer = v3(-sinf(tv) * 0.6f, sinf(tv) * 0.8f, cosf(tv));
        vx_answer a = {0};
        vicini_eval_shade(&rec, &q, &a);
        worst = fmax(worst, fabs(a.radiance.x - cosf(tl) / VX_PI) / (cosf(tl) / VX_PI));
    }
    CHECK_NEAR("a plate shades as Lambert (relative error, 4 light/view pairs)", worst, 0.0, 0.01);
    /* Lit from behind, seen from the front: the plate's mirrored normal faces away from the viewer. */
    q.to_light[0] = v3_normalize(v3(0.3f, 0, -1));
    q.to_viewer = v3_normalize(v3(-0.2f, 0.1f, 1));
    vx_answer a = {0};
    vicini_eval_shade(&rec, &q, &a);
    CHECK("a plate lit from behind is dark in front", a.radiance.x < 0.02f);
    CHECK("record: 11 bytes per voxel (Brito et al. section 5)", model_vicini.record.bytes == 11 && sizeof(vicini_record) == 11);
}

/* The C build's SSE phase function (vicini_phase_sse.h) against the scalar one it stands for (the
 * definition, and the OpenCL build's code), bit for bit: random records' distributions (and
 * degenerate ones: all codes 0, a needle, a plate) with random light and view directions, the axes,
 * the same and opposite directions. */
static void test_phase_sse(void)
{
#ifndef VX_SSE
    CHECK("the C build runs vicini's SSE phase function (SSE4.1 on the x86-64-v2 target)", 0);
#else
    rng g = rng_seed(21, 0);
    int n = 0, bad = 0, lit = 0;
    for (int k = 0; k < 20000; k++) {
        vicini_record r;
        memset(&r, 0, sizeof r);
        for (int c = 0; c < 3; c++) {
            r.sigma[c] = (unsigned char)(rng_u32(&g) & 255u);
            r.corr[c] = (unsigned char)(rng_u32(&g) % 255u);
        }
        if (k % 50 == 1)
            memset(&r, 0, sizeof r);
        if (k % 50 == 2)
            r.sigma[0] = r.sigma[1] = 0, r.sigma[2] = 255, r.corr[0] = r.corr[1] = r.corr[2] = 127;
        if (k % 50 == 3)
            r.sigma[0] = r.sigma[1] = 255, r.sigma[2] = 2, r.corr[0] = r.corr[1] = r.corr[2] = 127;
        float S[9];
        vicini_decode_sggx(&r, S);
        vec3 wi = v3_normalize(v3(2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f));
        vec3 wo = v3_normalize(v3(2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f));
        if (k % 7 == 0)
            wi = v3(k % 3 == 0, k % 3 == 1, k % 3 == 2);
        if (k % 11 == 0)
            wo = k % 2 ? wi : v3_scale(wi, -1.0f);
        float want = vicini_phase_diffuse_scalar(S, wi, wo), got = vicini_phase_diffuse_sse(S, wi, wo);
        bad += memcmp(&want, &got, sizeof want) != 0;
        lit += want > 0.0f;
        n++;
    }
    char name[160];
    snprintf(name, sizeof name, "the SSE diffuse phase function equals the scalar one, bit for bit (%d cases, %d lit, %d differ)",
             n, lit, bad);
    CHECK(name, bad == 0 && lit > n / 4);
#endif
}

/* ---------- moving records (tracer/dynamic/) ---------- */

static float opacity_toward(const vicini_record *r, vec3 w)
{
    vx_query q = {0};
    q.ray_dir = v3_normalize(w);
    return vicini_eval_opacity(r, &q);
}

/* The record's extinction per unit length toward w: density x SGGX projected area. (Not the voxel's
 * opacity: the voxel, an axis-aligned box, does not turn with its content, so its chord does not.) */
static float extinction_toward(const vicini_record *r, vec3 w)
{
    float S[9];
    vicini_decode_sggx(r, S);
    return vicini_decode_density(r->density) * vicini_sigma(S, v3_normalize(w));
}

/* A turned record must have toward R w the extinction the original has toward w, whatever the
 * turn: the six bytes are rescaled on re-encoding (a plate at 45 degrees has two diagonals of 1/2),
 * and the density must take that scale back. */
static void test_moving(void)
{
    vicini_record plate;
    bake(PLATE, &plate); /* normal +z */
    const float c = cosf(0.7853982f), s = sinf(0.7853982f);
    /* 45 degrees about y: the normal goes to (sin, 0, cos), S gets two diagonals of 1/2. */
    const float R[9] = {c, 0, s, 0, 1, 0, -s, 0, c};
    vicini_record turned;
    model_vicini.transform(&plate, R, &turned);
    const vec3 dirs[] = {v3(0, 0, 1), v3(1, 0, 0.2f), v3(0.3f, 0.5f, 0.8f), v3(-0.6f, 0.1f, 0.4f), v3(0, 1, 0.05f)};
    double worst = 0.0;
    for (size_t i = 0; i < sizeof dirs / sizeof dirs[0]; i++) {
        vec3 w = v3_normalize(dirs[i]);
        vec3 rw = v3(R[0] * w.x + R[1] * w.y + R[2] * w.z, R[3] * w.x + R[4] * w.y + R[5] * w.z,
                     R[6] * w.x + R[7] * w.y + R[8] * w.z);
        double a = extinction_toward(&turned, rw), b = extinction_toward(&plate, w);
        worst = fmax(worst, fabs(a / b - 1.0));
    }
    CHECK_NEAR("a record turned 45 degrees has toward R w the extinction it had toward w (5 directions, relative)",
               worst, 0.0, 0.06);
    /* Two halves of one record in one voxel are that record. */
    const vx_record_part parts[2] = {{&plate, 0.5f, {0, 0, 0}}, {&plate, 0.5f, {0, 0, 0}}};
    vicini_record whole;
    model_vicini.combine(parts, 2, 1.0f, &whole);
    worst = 0.0;
    for (size_t i = 0; i < sizeof dirs / sizeof dirs[0]; i++)
        worst = fmax(worst, fabs((double)opacity_toward(&whole, dirs[i]) - (double)opacity_toward(&plate, dirs[i])));
    CHECK_NEAR("two halves of a record combine into it (opacity, 5 directions)", worst, 0.0, 0.01);
    /* A turned record combined with an unturned one keeps the density-weighted extinction: the
     * combined density is the sum of both halves' whatever their encodings' scales. */
    const vx_record_part mixed[2] = {{&plate, 0.5f, {0, 0, 0}}, {&turned, 0.5f, {0, 0, 0}}};
    vicini_record both;
    model_vicini.combine(mixed, 2, 1.0f, &both);
    CHECK("combining a turned and an unturned plate leaves a non-empty, valid record",
          both.density > 0 && model_vicini.validate_record(&both, &(vx_record_context){0, 1.0f, 150}, (char[64]){0}, 64) == 0);
}

int main(void)
{
    test_inverse();
    test_inverse_remembered();
    test_linear_mix_without_exp();
    test_heterogeneous();
    test_estimator();
    test_bake();
    test_shading();
    test_phase_sse();
    test_moving();
    return unit_exit();
}
