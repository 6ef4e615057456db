/* The Heitz–Neyret model's numerics: one table of hard cases (every output finite and in range),
 * then checks of each piece against independent expectations: the mask table against the exact
 * area of a disk segment, the bake against synthetic Gaussian surfaces with known statistics, the
 * MIP combination against a plane seen at two levels, Smith's Lambda and the view-dependent colour
 * against their limits.
 *
 * `unit_heitz_neyret --lambda COS,SIGMA...` prints Lambda for each pair (%.9g): tests/
 * test_heitz_neyret.py compares those with an mpmath evaluation at 40 digits. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "bake_params.h"
#include "grid.h"
#include "hn_host.h"
#include "mesh.h"
#include "model.h"
#include "unit.h"

static struct vx_bake_params hn_defaults; /* the model's parameters at their defaults (main) */

static int finite3(vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

/* ---------- the test's own random numbers (xorshift64*) ---------- */

static uint64_t rnd_u64(uint64_t *s)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return *s * 0x2545F4914F6CDD1DULL;
}
static double rnd01(uint64_t *s) { return (double)(rnd_u64(s) >> 11) * (1.0 / 9007199254740992.0); }
static double rnd_gauss(uint64_t *s)
{
    double u = rnd01(s), v = rnd01(s);
    return sqrt(-2.0 * log(u + 1e-300)) * cos(2.0 * M_PI * v);
}

/* A uniform-ish sample of the query space's awkward corners: one element answer per case. */
typedef struct {
    const char *name;
    vec3 n;          /* blended mean normal (not unit) */
    float D;         /* distance of the element's centre above the plane */
    float var_h, var_n;
    float two_sided;
    vec3 ray_dir;    /* unit or not */
    float r;         /* element radius */
    int lights;
    float light_cos; /* cos of the light to +z */
    unsigned effects;
} element_case;

static const element_case element_cases[] = {
    {"facing the ray, nx = ny = 0", {0, 0, 1}, 0.0f, 0.01f, 0.1f, 0, {0, 0, -1}, 0.5f, 1, 1.0f, 0},
    {"facing away, nx = ny = 0", {0, 0, 1}, 0.2f, 0.01f, 0.1f, 0, {0, 0, 1}, 0.5f, 1, 1.0f, 0},
    {"edge-on (nz = 0)", {1, 0, 0}, 0.0f, 0.0f, 0.0f, 0, {0, 0, 1}, 0.5f, 1, 0.5f, VX_EFFECT_SPECULAR},
    {"edge-on and rough", {0, 1, 0}, 0.1f, 0.04f, 4.0f, 0, {0, 0, 1}, 0.5f, 1, 0.5f, VX_EFFECT_SHADOWS},
    {"mean normal of length 0", {0, 0, 0}, 0.0f, 0.01f, 1.0f, 0, {0, 0.6f, -0.8f}, 0.5f, 1, 0.7f, 0},
    {"mean normal of length 0, two-sided", {0, 0, 0}, 0.0f, 0.01f, 1.0f, 1, {0, 0.6f, -0.8f}, 0.5f, 1, 0.7f, 0},
    {"sigma_n = 0", {0, 0, 1}, 0.0f, 0.0f, 0.0f, 0, {0.6f, 0, -0.8f}, 0.5f, 1, 0.9f, VX_EFFECT_SPECULAR},
    {"sigma_n huge", {0, 0, 1}, 0.0f, 0.01f, 1e8f, 0, {0.6f, 0, -0.8f}, 0.5f, 1, 0.9f,
     VX_EFFECT_SPECULAR | VX_EFFECT_SHADOWS},
    {"sigma_h = 0 (g a step)", {0, 0, 1}, 0.1f, 0.0f, 0.3f, 0, {0.6f, 0, -0.8f}, 0.5f, 1, 0.9f, VX_EFFECT_SHADOWS},
    {"sigma_h huge", {0, 0, 1}, 0.1f, 1e12f, 0.3f, 0, {0.6f, 0, -0.8f}, 0.5f, 1, 0.9f, 0},
    {"grazing view 89.99 deg", {0, 0, 1}, 0.0f, 0.01f, 0.3f, 0, {0.99999998f, 0, -0.0002f}, 0.5f, 1, 0.5f,
     VX_EFFECT_SHADOWS | VX_EFFECT_SPECULAR},
    {"grazing light", {0, 0, 1}, 0.0f, 0.01f, 0.3f, 0, {0, 0, -1}, 0.5f, 1, 1e-7f, VX_EFFECT_SHADOWS},
    {"light behind the surface", {0, 0, 1}, 0.0f, 0.01f, 0.3f, 0, {0, 0, -1}, 0.5f, 1, -0.5f,
     VX_EFFECT_SHADOWS | VX_EFFECT_SPECULAR},
    {"element radius 0", {0, 0, 1}, 0.0f, 0.01f, 0.3f, 0, {0.3f, 0.4f, -0.866f}, 0.0f, 1, 0.9f, 0},
    {"element radius huge", {0, 0, 1}, 1.0f, 0.01f, 0.3f, 0, {0.3f, 0.4f, -0.866f}, 1e30f, 1, 0.9f, 0},
    {"far above (v << -1)", {0.3f, 0, 1}, 1e6f, 0.01f, 0.3f, 0, {0.3f, 0.4f, -0.866f}, 0.5f, 1, 0.9f, 0},
    {"far below (v >> 1)", {0.3f, 0, 1}, -1e6f, 0.01f, 0.3f, 0, {0.3f, 0.4f, -0.866f}, 0.5f, 1, 0.9f, 0},
    {"NaN distance", {0.3f, 0, 1}, NAN, 0.01f, 0.3f, 0, {0.3f, 0.4f, -0.866f}, 0.5f, 1, 0.9f, 0},
    {"zero ray direction", {0, 0, 1}, 0.0f, 0.01f, 0.3f, 0, {0, 0, 0}, 0.5f, 1, 0.9f, 0},
    {"no lights", {0, 0, 1}, 0.0f, 0.01f, 0.3f, 0, {0, 0, -1}, 0.5f, 0, 0.9f, 0},
};

static void element_table(void)
{
    const unsigned *table = hn_mask_table();
    for (size_t i = 0; i < sizeof element_cases / sizeof element_cases[0]; i++) {
        const element_case *c = &element_cases[i];
        hn_sample s;
        memset(&s, 0, sizeof s);
        s.n = c->n;
        s.D = c->D;
        s.var_h = c->var_h;
        s.var_n = c->var_n;
        s.two_sided = c->two_sided;
        s.a = v3(0.5f, 0.6f, 0.7f);
        s.as = v3(0.3f, -0.2f, 0.1f);
        s.f0 = 0.5f;
        s.var_brdf = 0.0f; /* a mirror microsurface: only sigma_n makes the lobe finite */
        vx_query q;
        memset(&q, 0, sizeof q);
        q.ray_dir = c->ray_dir;
        q.to_viewer = v3_scale(c->ray_dir, -1.0f);
        q.effects = c->effects;
        q.light_count = c->lights;
        float st = sqrtf(fmaxf(0.0f, 1.0f - c->light_cos * c->light_cos));
        q.to_light[0] = v3(st, 0.0f, c->light_cos);
        q.irradiance[0] = v3(3.0f, 3.0f, 3.0f);
        vx_answer a;
        hn_answer(table, &s, &q, c->r, &a);
        char name[160];
        snprintf(name, sizeof name, "element: %s: finite, opacity in [0,1], radiance >= 0", c->name);
        /* Bound: irradiance x (albedo / pi + the Beckmann lobe's peak at the smallest alpha the
         * model allows, 1e-3: f0 / (pi alpha^2) / 4 cos^2 ... generous but finite). */
        CHECK(name, finite3(a.radiance) && a.radiance.x >= 0 && a.radiance.y >= 0 && a.radiance.z >= 0 &&
                        isfinite(a.opacity) && a.opacity >= 0.0f && a.opacity <= 1.0f && a.radiance.x < 1e12f);
        snprintf(name, sizeof name, "element: %s: opacity = mask popcount / 128", c->name);
        CHECK(name, fabsf(a.opacity - (float)hn_mask_count(a.mask) / 128.0f) < 1e-6f);
    }
}

/* ---------- scalar functions at their limits ---------- */

typedef struct {
    const char *name;
    float cos_theta, sigma;
} lambda_case;

static const lambda_case lambda_cases[] = {
    {"theta = 0", 1.0f, 0.3f},        {"theta -> 0", 1.0f - 1e-7f, 0.3f}, {"theta = 90", 0.0f, 0.3f},
    {"theta -> 90", 1e-7f, 0.3f},     {"behind", -0.5f, 0.3f},           {"sigma = 0", 0.5f, 0.0f},
    {"sigma tiny", 0.5f, 1e-30f},     {"sigma huge", 0.5f, 1e30f},       {"NaN cos", NAN, 0.3f},
    {"NaN sigma", 0.5f, NAN},         {"erfc tail x = 9.49", 0.99f, 0.7f / 9.49f}, /* x ~ 9.49 */
    {"erfc tail x = 2", 0.8f, 0.4714f}, {"infinite sigma", 0.5f, INFINITY},
};

static void scalar_table(void)
{
    for (size_t i = 0; i < sizeof lambda_cases / sizeof lambda_cases[0]; i++) {
        const lambda_case *c = &lambda_cases[i];
        float L = hn_lambda(c->cos_theta, c->sigma);
        float dh = hn_visible_depth_offset(0.1f, L);
        float a = hn_attribute(0.5f, 0.3f, L, L);
        float tilt = hn_visible_tilt(hn_cot_from_cos(c->cos_theta), c->sigma);
        float k = hn_lambert_cos_mean(c->sigma);
        char name[160];
        snprintf(name, sizeof name, "scalar: %s: Lambda, h(v), a(v,l), tilt, cos mean finite and in range", c->name);
        CHECK(name, isfinite(L) && L >= 0.0f && isfinite(dh) && dh >= 0.0f && isfinite(a) && a >= 0.5f && a <= 0.8f &&
                        isfinite(tilt) && tilt >= 0.0f && isfinite(k) && k >= 0.0f && k <= 1.0f);
    }
    CHECK_NEAR("Lambda(theta = 0) = 0", hn_lambda(1.0f, 0.3f), 0.0, 0.0);
    CHECK_NEAR("Lambda(sigma = 0) = 0", hn_lambda(0.3f, 0.0f), 0.0, 0.0);
    /* Grazing: Lambda ~ sigma / (mu sqrt(2 pi)) - 1/2 for mu << sigma. */
    float mu = hn_cot_from_cos(1e-3f);
    CHECK_NEAR("Lambda grazing asymptote", hn_lambda(1e-3f, 0.5f), 0.5 / (mu * sqrt(2 * M_PI)) - 0.5, 1e-3);
    CHECK_NEAR("a(v,l) = a at normal incidence", hn_attribute(0.4f, 0.2f, 0.0f, 0.0f), 0.4, 1e-7);
    CHECK_NEAR("a(v,l) -> a + a_s at grazing", hn_attribute(0.4f, 0.2f, 1e30f, 0.0f), 0.6, 1e-6);
    CHECK_NEAR("a(v,l) eq. 17 at Lambda = 1", hn_attribute(0.4f, 0.2f, 0.5f, 0.5f), 0.4 + 0.2 * (2.0 * 2 / 3 - 1), 1e-6);
    /* g(h) with sigma_h = 0 is a step. */
    CHECK("g(h) with sigma_h = 0 is a step",
          hn_g(-1e-20f, 0.0f) == 0.0f && hn_g(1e-20f, 0.0f) == 1.0f && hn_g(0.0f, 0.0f) == 0.5f);
    CHECK_NEAR("g(0) = 1/2", hn_g(0.0f, 0.2f), 0.5, 1e-7);
    CHECK_NEAR("g(sigma) = Phi(1)", hn_g(0.2f, 0.2f), 0.841344746, 1e-6);
    /* erfcx tail: sqrt(pi) erfcx(y) -> 1/y. */
    CHECK_NEAR("erfcx tail", hn_sqrtpi_erfcx(1e4f) * 1e4f, 1.0, 1e-6);
    CHECK_NEAR("erfcx at 2 (branch point)", hn_sqrtpi_erfcx(2.0f), sqrt(M_PI) * exp(4.0) * erfc(2.0), 2e-6);
    CHECK_NEAR("erfcx just past 2", hn_sqrtpi_erfcx(2.0001f), sqrt(M_PI) * exp(2.0001 * 2.0001) * erfc(2.0001), 2e-6);
    /* Visible tilt: sigma^2 / mu for flat views, ~1.25 sigma at grazing. */
    CHECK_NEAR("visible tilt, small sigma", hn_visible_tilt(1.0f, 0.01f), 1e-4, 1e-7);
    CHECK_NEAR("visible tilt, grazing", hn_visible_tilt(1e-6f, 0.3f), 0.3 * sqrt(2 * M_PI) / 2, 1e-4);
    /* Half floats. */
    float hv[] = {0.0f, 1e-7f, 6.1e-5f, 0.333333f, 1.0f, 1000.5f, 65504.0f, -2.5f};
    int ok = 1;
    for (size_t i = 0; i < sizeof hv / sizeof hv[0]; i++) {
        float back = hn_half_to_float(hn_float_to_half(hv[i]));
        ok &= fabsf(back - hv[i]) <= fmaxf(fabsf(hv[i]) * 4.9e-4f, 3e-8f);
    }
    CHECK("half float round trip within half an ulp", ok);
    CHECK("half float saturates", hn_half_to_float(hn_float_to_half(1e30f)) == 65504.0f &&
                                      hn_half_to_float(hn_float_to_half(NAN)) == 0.0f);
    /* Every half against its definition by ldexp: (-1)^s m 2^-24 (subnormal), (-1)^s (1 + m/1024)
     * 2^(e-15), 65504 for infinity and NaN; bit for bit, signed zeros too. */
    int wrong = 0;
    for (unsigned h = 0; h < 65536u; h++) {
        unsigned e = (h >> 10) & 31u, m = h & 1023u;
        double ref = e == 0u ? ldexp((double)m, -24) : (e == 31u ? 65504.0 : ldexp(1.0 + m / 1024.0, (int)e - 15));
        float want = (float)((h & 0x8000u) ? -ref : ref), got = hn_half_to_float(h);
        wrong += memcmp(&want, &got, sizeof got) != 0;
    }
    CHECK("half float: all 65536 halves as their definition, bit for bit", wrong == 0);
    /* Slope variance from normals' second moment, round trip and limits. */
    ok = 1;
    for (double s2 = 1e-6; s2 < 1e4; s2 *= 3.7)
        ok &= fabs(hn_sigma2_of_m(hn_m_of_sigma2(s2)) / s2 - 1.0) < 1e-6;
    CHECK("sigma_n^2 from E[(n.N)^2]: round trip", ok);
    CHECK("sigma_n^2 from E[(n.N)^2]: flat and degenerate", hn_sigma2_of_m(1.0) == 0.0 && isfinite(hn_sigma2_of_m(0.0)) &&
                                                               hn_sigma2_of_m(0.0) > 1e3 && isfinite(hn_sigma2_of_m(NAN)));
}

/* ---------- the coverage masks ---------- */

/* Area fraction of the unit disk where x <= v. */
static double segment_fraction(double v)
{
    if (v <= -1)
        return 0;
    if (v >= 1)
        return 1;
    return (M_PI - acos(v) + v * sqrt(1 - v * v)) / M_PI;
}

/* Whether the element's ray through r omega has a point z in [-r - behind, r] meeting every
 * constraint A + r omega.c + b z <= 0, each loosened by `slack` (negative: tightened): the interval
 * of z, bound by bound. */
static int constraints_feasible(const hn_constraint *c, int n, float r, float behind, double ox, double oy,
                                double slack)
{
    double lo = -r - behind - fabs(slack) * (slack > 0 ? 1 : -1) * r, hi = r + (slack > 0 ? 1 : -1) * fabs(slack) * r;
    for (int i = 0; i < n; i++) {
        double a = c[i].A + r * (ox * c[i].cx + oy * c[i].cy) - slack * r * (fabs(c[i].cx) + fabs(c[i].cy) + fabs(c[i].b));
        if (c[i].b > 0)
            hi = fmin(hi, -a / c[i].b);
        else if (c[i].b < 0)
            lo = fmax(lo, -a / c[i].b);
        else if (a > 0)
            return 0;
    }
    return lo <= hi;
}

/* One to three random constraints (planes, sheets, edges at any angle to the ray) into c, and a
 * segment extended toward the viewer or not (*behind 1 or 0); returns how many. */
static int random_constraints(uint64_t *seed, hn_constraint c[3], float *behind)
{
    int n = 1 + (int)(rnd01(seed) * 3);
    for (int i = 0; i < n; i++) {
        double z = 2 * rnd01(seed) - 1, ph = 2 * M_PI * rnd01(seed), sz = sqrt(1 - z * z);
        c[i].cx = (float)(sz * cos(ph)), c[i].cy = (float)(sz * sin(ph)), c[i].b = (float)z;
        c[i].A = (float)(1.6 * rnd01(seed) - 0.8);
    }
    *behind = rnd01(seed) < 0.5 ? 0.0f : 1.0f;
    return n;
}

/* hn_constraints_empty, which the cone element asks with the plane's bounds before it blends the
 * edge field: on random sets of one to three constraints, whenever it says a prefix of the set is
 * empty, the mask of the whole set is empty and the brute force finds no sample that meets the
 * prefix (beyond the table's slack); and it does say so for most of the prefixes whose mask is
 * empty (an answer of "never" would make the early exit useless, and "always" wrong). */
static void constraints_empty_prefix(const float *smp, const unsigned *table)
{
    uint64_t seed = 7;
    long said_empty = 0, empty_masks = 0, caught = 0, wrong = 0;
    for (int t = 0; t < 4000; t++) {
        hn_constraint c[3];
        float r = 0.5f, behind;
        int n = random_constraints(&seed, c, &behind);
        int k = 1 + (int)(rnd01(&seed) * n); /* the prefix c[0 .. k - 1] */
        unsigned prefix_mask[VX_MASK_WORDS], whole[VX_MASK_WORDS];
        hn_constraints_mask(table, c, k, r, behind, prefix_mask);
        hn_constraints_mask(table, c, n, r, behind, whole);
        int empty = hn_constraints_empty(c, k, r, behind);
        empty_masks += hn_mask_count(prefix_mask) == 0;
        if (!empty)
            continue;
        said_empty++;
        caught += hn_mask_count(prefix_mask) == 0;
        int feasible = 0;
        for (int s = 0; s < HN_MASK_SAMPLES; s++)
            feasible += constraints_feasible(c, k, r, behind, smp[2 * s], smp[2 * s + 1], -0.03);
        wrong += hn_mask_count(whole) != 0 || hn_mask_count(prefix_mask) != 0 || feasible != 0;
    }
    printf("# constraints_empty: %ld of 4000 prefixes said empty, %ld wrong; %ld of the %ld empty prefix masks caught\n",
           said_empty, wrong, caught, empty_masks);
    CHECK("a prefix said empty has an empty mask, as has the whole set, and no sample meets it", wrong == 0);
    CHECK("most empty prefix masks are said empty before the table is read", said_empty > 0 && caught * 10 >= empty_masks * 8);
}

/* hn_constraints_mask against a brute-force test of each sample's segment, on random sets of one
 * to three constraints (planes, sheets, edges at any angle to the ray). The table quantises angles
 * and offsets, so samples within a small slack of the boundary may go either way; every other
 * sample must agree. Also the case the exact test exists for: a tilted plate's far edge. */
static void constraints_brute_force(const float *smp, const unsigned *table)
{
    uint64_t seed = 99;
    long wrong = 0, ambiguous = 0, total = 0;
    for (int t = 0; t < 4000; t++) {
        hn_constraint c[3];
        float r = 0.5f, behind;
        int n = random_constraints(&seed, c, &behind);
        unsigned m[VX_MASK_WORDS];
        hn_constraints_mask(table, c, n, r, behind, m);
        for (int s = 0; s < HN_MASK_SAMPLES; s++) {
            int bit = (m[s / 32] >> (s % 32)) & 1u;
            int loose = constraints_feasible(c, n, r, behind, smp[2 * s], smp[2 * s + 1], 0.03);
            int strict = constraints_feasible(c, n, r, behind, smp[2 * s], smp[2 * s + 1], -0.03);
            total++;
            if (loose != strict)
                ambiguous++;
            else if (bit != loose)
                wrong++;
        }
    }
    printf("# constraint masks: %ld of %ld samples wrong, %ld within the table's quantisation\n", wrong, total,
           ambiguous);
    CHECK("constraint masks agree with a per-sample brute force outside the table's quantisation", wrong == 0);
    CHECK("the quantisation band is narrow (< 5 % of samples)", ambiguous < total / 20);
    /* A plate tilted 60 degrees about the footprint's x axis through the element's centre, facing
     * the ray, its edge plane u across it 0.1 from the centre: the rays whose points below the
     * plate all lie beyond the edge (they cross the plane past it) are not covered; the AND of the
     * two separate masks covered them too, about twice the exact count. */
    double th = 60.0 * M_PI / 180.0;
    float e = 0.1f;
    hn_constraint plate = {0.0f, 0.0f, (float)sin(th), (float)-cos(th)};
    hn_constraint edge = {e, 0.0f, (float)cos(th), (float)sin(th)};
    hn_constraint both[2] = {plate, edge};
    unsigned m[VX_MASK_WORDS], mp[VX_MASK_WORDS], me[VX_MASK_WORDS];
    hn_constraints_mask(table, both, 2, 0.5f, 0.0f, m);
    hn_constraints_mask(table, &plate, 1, 0.5f, 0.0f, mp);
    hn_constraints_mask(table, &edge, 1, 0.5f, 0.0f, me);
    int separate = 0;
    for (int w = 0; w < VX_MASK_WORDS; w++)
        separate += __builtin_popcount(mp[w] & me[w]);
    int brute = 0;
    for (int s = 0; s < HN_MASK_SAMPLES; s++)
        brute += constraints_feasible(both, 2, 0.5f, 0.0f, smp[2 * s], smp[2 * s + 1], 0.0);
    printf("# plate past its far edge: exact mask %d samples, brute force %d, separate masks ANDed %d\n",
           hn_mask_count(m), brute, separate);
    CHECK("a ray past a tilted plate's far edge is not covered (exact mask)", abs(hn_mask_count(m) - brute) <= 3 &&
                                                                               separate > brute + 10);
    /* A sheet is met only on its plane: edge-on (b = 0 for both bounds) it covers nothing. */
    hn_constraint sheet[2] = {{0.0f, 1.0f, 0.0f, 0.0f}, {0.0f, -1.0f, 0.0f, 0.0f}};
    hn_constraints_mask(table, sheet, 2, 0.5f, 1.0f, m);
    CHECK("a sheet seen edge-on covers (almost) nothing", hn_mask_count(m) <= 4);
    hn_constraint facing[2] = {{0.3f, 0.0f, 0.0f, -1.0f}, {-0.3f, 0.0f, 0.0f, 1.0f}};
    hn_constraints_mask(table, facing, 2, 0.5f, 0.0f, m);
    CHECK("a sheet facing the ray inside the segment covers all", hn_mask_count(m) == 128);
    facing[0].A = -0.8f, facing[1].A = 0.8f; /* the crossing at z = -0.8, before the segment */
    hn_constraints_mask(table, facing, 2, 0.5f, 0.0f, m);
    CHECK("a sheet crossed before the segment covers nothing", hn_mask_count(m) == 0);
    hn_constraints_mask(table, facing, 2, 0.5f, 1.0f, m);
    CHECK("... unless the segment reaches back to it", hn_mask_count(m) == 128);
}

/* The shipped sample positions are the generator's, bit for bit; the table built from them by the
 * per-angle sweep is the brute-force one (every sample tested against every entry, as the table's
 * definition reads), and the float positions are the doubles rounded. */
static void mask_provenance(void)
{
    static double gen[HN_MASK_SAMPLES][2];
    hn_mask_points_generate(gen);
    CHECK("mask samples: the shipped positions are the generator's, bit for bit",
          memcmp(gen, hn_mask_points, sizeof gen) == 0);
    const float *smp = hn_mask_samples();
    int rounded = 1;
    for (int s = 0; s < HN_MASK_SAMPLES; s++)
        rounded &= smp[2 * s] == (float)hn_mask_points[s][0] && smp[2 * s + 1] == (float)hn_mask_points[s][1];
    CHECK("mask samples: the float positions are the shipped doubles rounded", rounded);
    const unsigned *table = hn_mask_table();
    size_t wrong = 0;
    for (int ti = 0; ti < HN_TABLE_T; ti++) {
        double t = 2.0 * M_PI * ti / HN_TABLE_T, ct = cos(t), st = sin(t);
        for (int vi = 0; vi < HN_TABLE_V; vi++) {
            double v = -1.0 + (vi + 0.5) * 2.0 / HN_TABLE_V;
            unsigned m[VX_MASK_WORDS] = {0};
            for (int s = 0; s < HN_MASK_SAMPLES; s++)
                if (hn_mask_points[s][0] * ct + hn_mask_points[s][1] * st <= v)
                    m[s / 32] |= 1u << (s % 32);
            wrong += memcmp(m, &table[((size_t)ti * HN_TABLE_V + (size_t)vi) * VX_MASK_WORDS], sizeof m) != 0;
        }
    }
    CHECK("mask table: every entry equals the brute-force half-plane test", wrong == 0);
}

static void masks(void)
{
    const float *smp = hn_mask_samples();
    const unsigned *table = hn_mask_table();
    double dmin = 1e9;
    int inside = 1;
    for (int i = 0; i < HN_MASK_SAMPLES; i++) {
        inside &= smp[2 * i] * smp[2 * i] + smp[2 * i + 1] * smp[2 * i + 1] <= 1.0f;
        for (int k = 0; k < i; k++)
            dmin = fmin(dmin, hypot(smp[2 * i] - smp[2 * k], smp[2 * i + 1] - smp[2 * k + 1]));
    }
    CHECK("mask samples lie in the unit disk", inside);
    /* Poisson-disk: pure random points would come within ~0.01 of each other; a dense Poisson
     * packing of 128 points in the unit disk keeps them about 0.15 apart. */
    printf("# mask samples: minimum distance %.4f\n", dmin);
    CHECK("mask samples are Poisson-disk distributed (min distance > 0.1)", dmin > 0.1);
    double worst = 0, sum = 0;
    int n = 0;
    for (int ti = 0; ti < HN_TABLE_T; ti += 3)
        for (int vi = 0; vi < HN_TABLE_V; vi += 3) {
            double v = -1.0 + (vi + 0.5) * 2.0 / HN_TABLE_V;
            unsigned m[VX_MASK_WORDS];
            hn_mask_lookup(table, 2.0f * (float)M_PI * (float)ti / HN_TABLE_T, (float)v, m);
            double e = fabs(hn_mask_count(m) / 128.0 - segment_fraction(v));
            worst = fmax(worst, e);
            sum += e;
            n++;
        }
    printf("# mask coverage vs exact segment area: mean error %.4f, worst %.4f\n", sum / n, worst);
    /* 128 samples quantise the fraction by 1/128 and place it with their own jitter: a relaxed
     * Poisson set stays within about one sample on average and six at worst. */
    CHECK("mask coverage tracks the disk segment's area (mean error < 1.3/128)", sum / n < 1.3 / 128.0);
    CHECK("mask coverage tracks the disk segment's area (worst < 6/128)", worst < 6.0 / 128.0);
    unsigned m[VX_MASK_WORDS];
    hn_mask_lookup(table, 0.3f, -1.0f, m);
    CHECK("v = -1 covers nothing", hn_mask_count(m) == 0);
    hn_mask_lookup(table, 0.3f, 1.0f, m);
    CHECK("v = 1 covers everything", hn_mask_count(m) == 128);
    hn_mask_lookup(table, 0.3f, -1e30f, m);
    CHECK("v far below the table covers nothing", hn_mask_count(m) == 0);
    hn_mask_lookup(table, 0.3f, INFINITY, m);
    CHECK("v = inf covers everything", hn_mask_count(m) == 128);
    hn_mask_lookup(table, 0.3f, NAN, m);
    CHECK("v = NaN covers nothing", hn_mask_count(m) == 0);
    hn_mask_lookup(table, 1e30f, 0.0f, m);
    CHECK("angle far outside [0, 2 pi) is still a valid entry", hn_mask_count(m) > 30 && hn_mask_count(m) < 98);
    /* Opposite half-planes are complementary (up to samples on the line). */
    unsigned a[VX_MASK_WORDS], b[VX_MASK_WORDS];
    hn_mask_lookup(table, 0.0f, 0.0f, a);
    hn_mask_lookup(table, (float)M_PI, 0.0f, b);
    int overlap = 0, uni = 0;
    for (int w = 0; w < VX_MASK_WORDS; w++) {
        overlap += __builtin_popcount(a[w] & b[w]);
        uni += __builtin_popcount(a[w] | b[w]);
    }
    CHECK("opposite half-planes cover complementary samples", overlap <= 2 && uni >= 126);
    /* Plane masks: head-on, edge-on. */
    /* One plane (A + r omega.c + b z <= 0: the centre 0.4 / 0.6 above a plane facing the ray, r = 0.5). */
    hn_constraint facing_near = {0.4f, 0.0f, 0.0f, -1.0f}, facing_far = {0.6f, 0.0f, 0.0f, -1.0f};
    hn_constraint edge_on = {0.0f, 1.0f, 0.0f, 0.0f};
    hn_constraints_mask(table, &facing_near, 1, 0.5f, 0.0f, m);
    CHECK("plane facing the ray within reach covers all", hn_mask_count(m) == 128);
    hn_constraints_mask(table, &facing_far, 1, 0.5f, 0.0f, m);
    CHECK("plane facing the ray out of reach covers nothing", hn_mask_count(m) == 0);
    hn_constraints_mask(table, &edge_on, 1, 0.5f, 0.0f, m);
    CHECK("voxel edge-on through the centre covers half", abs(hn_mask_count(m) - 64) <= 4);
    constraints_brute_force(smp, table);
    constraints_empty_prefix(smp, table);
}

/* ---------- the bake against a synthetic Gaussian surface ---------- */

/* Hits of a horizontal Gaussian height field inside the unit voxel [0,1]^3: heights N(h0, s^2)
 * around z = 0.5 + h0, normals with slopes N(0, sn^2) per axis, albedo a + d erf(h/(sqrt2 s)). The
 * directions come from above (front hits) and are uniform on the upper hemisphere. */
static void bake_gaussian(const vx_model *m, double h0, double s, double sn, double abar, double d, hn_record *rec,
                          int n)
{
    vx_sample *smp = calloc((size_t)n, sizeof *smp);
    uint64_t r = 12345;
    for (int i = 0; i < n; i++) {
        double h = rnd_gauss(&r) * s, px = rnd01(&r), py = rnd01(&r);
        double p = rnd_gauss(&r) * sn, q = rnd_gauss(&r) * sn, len = sqrt(1 + p * p + q * q);
        double z = 2 * rnd01(&r) - 1, phi = 2 * M_PI * rnd01(&r), sz = sqrt(1 - z * z);
        vec3 dir = v3((float)(sz * cos(phi)), (float)(sz * sin(phi)), (float)-fabs(z));
        vec3 hit = v3((float)px, (float)py, (float)(0.5 + h0 + h));
        smp[i].origin = v3_madd(hit, dir, -10.0f);
        smp[i].dir = dir;
        smp[i].t_entry = 9.0f;
        smp[i].t_exit = 11.0f;
        smp[i].t_hit = 10.0f;
        smp[i].kind = VX_SAMPLE_INSIDE_FRONT;
        smp[i].normal = v3((float)(-p / len), (float)(-q / len), (float)(1 / len));
        float c = (float)(abar + d * erf(h / (M_SQRT2 * s)));
        smp[i].albedo = v3(c, c, 0.5f);
        smp[i].specular = 0.04f;
        smp[i].roughness = 0.3f;
    }
    vx_voxel v = {0, 0, 0, 0, v3(0, 0, 0), 1.0f, 0, NULL};
    memset(rec, 0, sizeof *rec);
    m->bake_voxel(&v, smp, n, rec);
    free(smp);
}

static void bake(void)
{
    const vx_model *m = model_find("heitz-neyret");
    CHECK("registered as heitz-neyret", m != NULL);
    if (!m)
        return;
    CHECK("record is 28 bytes", m->record.bytes == 28 && sizeof(hn_record) == 28);
    CHECK("declares cone marching, coverage masks and levels",
          m->cone != NULL && vx_model_compositing(m) == VX_COMPOSITE_COVERAGE && m->record.levels && m->cone->element.fn);
    hn_record rec;
    hn_data d;
    bake_gaussian(m, 0.1, 0.05, 0.3, 0.5, 0.3, &rec, 20000);
    hn_decode(&rec, 1.0f, &d);
    printf("# bake: h %.4f sigma_h %.4f sigma_n %.4f a %.4f a_s %.4f two %d\n", d.h, sqrt(d.var_h), sqrt(d.var_n), d.a.x,
           d.as.x, d.two_sided);
    CHECK_NEAR("bake: mean height along the mean normal", d.h, 0.1, 0.005);
    CHECK_NEAR("bake: sigma_h", sqrt(d.var_h), 0.05, 0.003);
    CHECK_NEAR("bake: sigma_n (slopes from normals' second moment)", sqrt(d.var_n), 0.3, 0.02);
    CHECK_NEAR("bake: mean colour", d.a.x, 0.5, 0.01);
    CHECK_NEAR("bake: a_s = projection of the colour on s(h)", d.as.x, 0.3, 0.015);
    CHECK_NEAR("bake: uncorrelated channel has a_s = 0", d.as.z, 0.0, 0.01);
    CHECK("bake: one-sided, normal up", !d.two_sided && d.n.z > 0.9f);
    CHECK_NEAR("bake: material roughness kept", sqrt(2 * d.var_brdf), 0.3, 0.005);
    /* sigma_h = 0: a flat plane; a_s must be 0 (no depth to correlate with), nothing NaN. */
    bake_gaussian(m, -0.2, 0.0, 0.0, 0.3, 0.0, &rec, 500);
    hn_decode(&rec, 1.0f, &d);
    CHECK("bake: flat plane: sigma_h = sigma_n = a_s = 0",
          d.var_h < 1e-8f && d.var_n < 1e-6f && d.as.x == 0.0f && fabsf(d.h + 0.2f) < 1e-3f);
    /* Opposite normals (a double-sided sheet hit from both sides) -> two-sided axis. */
    vx_sample two[400];
    memset(two, 0, sizeof two);
    for (int i = 0; i < 400; i++) {
        float sgn = i % 2 ? 1.0f : -1.0f;
        vec3 dir = v3(0.1f, 0.2f, -sgn);
        dir = v3_normalize(dir);
        vec3 hit = v3(0.1f + 0.002f * (float)i, 0.3f + 0.001f * (float)i, 0.5f);
        two[i] = (vx_sample){v3_madd(hit, dir, -5.0f), dir, 4.5f, 5.5f, 5.0f, VX_SAMPLE_INSIDE_FRONT,
                             v3(0, 0, sgn), v3(0.2f, 0.8f, 0.2f), 0, 0.5f, 0, 0};
    }
    vx_voxel v = {0, 0, 0, 0, v3(0, 0, 0), 1.0f, 0, NULL};
    m->bake_voxel(&v, two, 400, &rec);
    hn_decode(&rec, 1.0f, &d);
    CHECK("bake: opposite normals give a two-sided sheet along their axis",
          d.two_sided && fabsf(fabsf(d.n.z) - 1.0f) < 1e-3f && fabsf(fabsf(d.h) - 0.0f) < 1e-3f);
    /* No hit at all: area 0 (ignored by the interpolation). */
    memset(&rec, 0, sizeof rec);
    m->bake_voxel(&v, two, 0, &rec);
    hn_decode(&rec, 1.0f, &d);
    CHECK("bake: no samples -> empty record", d.area == 0.0f);
}

/* ---------- a real grid: MIP levels, stencils, wide cones ---------- */

/* The MIP levels keep where a surface ends: a plate at z = 0.3 over x in [0, 0.61] (the edge
 * falls inside cells at every level), level-0 records with the exact area and psi (the in-plane
 * distance from the cell's centre to the edge, clamped to +-size/2); every coarser cell that the
 * edge cuts must put the edge within 2 % of its size of where it is (snorm8 psi: 0.4 %). The
 * moments alone (each child's patch at its centre) put it 7.7 % of the cell outward here. */
static void mip_edge(void)
{
    const vx_model *m = model_find("heitz-neyret");
    if (!m)
        return;
    const float E = 0.61f;
    mesh me;
    memset(&me, 0, sizeof me);
    mesh_add_quad(&me, v3(0, 0, 0.3f), v3(E, 0, 0.3f), v3(E, 1, 0.3f), v3(0, 1, 0.3f), 0);
    mesh_add_flat_triangle(&me, v3(0, 0, 0), v3(0.001f, 0, 0), v3(0, 0.001f, 0), 0);
    mesh_add_flat_triangle(&me, v3(1, 1, 0), v3(0.999f, 1, 0), v3(1, 0.999f, 0), 0); /* bounds up to x = 1 */
    voxel_grid g;
    vx_err e;
    if (grid_build(&g, &me, 32, &e)) {
        CHECK("grid builds", 0);
        mesh_free(&me);
        return;
    }
    hn_record *recs = calloc(bake_record_count(m, &g), sizeof *recs);
    float vs = (float)g.voxel_size;
    for (size_t i = 0; i < grid_count(&g, 0); i++) {
        int x, y, z;
        grid_coords(&g, 0, i, &x, &y, &z);
        vec3 c = grid_cell_center(&g, 0, x, y, z);
        hn_data d;
        memset(&d, 0, sizeof d);
        float covered = fminf(fmaxf(E - (c.x - 0.5f * vs), 0.0f), vs);
        if (fabsf(c.z - 0.3f) < 0.5f * vs && c.y > 0.05f && c.y < 0.95f && covered > 0.0f) {
            d.n = v3(0, 0, 1);
            d.h = 0.3f - c.z;
            d.area = covered * vs;
            d.psi = fminf(fmaxf(c.x - E, -0.5f * vs), 0.5f * vs);
            d.a = v3(0.5f, 0.5f, 0.5f);
            d.has_color = 1;
        }
        hn_encode(&d, vs, &recs[i]);
    }
    CHECK("bake_finish succeeds (edge)", m->bake_finish(&g, recs, &hn_defaults) == 0);
    double worst = 0;
    int cut = 0;
    size_t off = grid_count(&g, 0);
    for (int l = 1; l < g.levels; l++) {
        float size = (float)ldexp(vs, l);
        for (size_t i = 0; i < grid_count(&g, l); i++) {
            int x, y, z;
            grid_coords(&g, l, i, &x, &y, &z);
            vec3 c = grid_cell_center(&g, l, x, y, z);
            hn_data d;
            hn_decode(&recs[off + i], size, &d);
            float want = c.x - E;
            if (!(d.area > 0.0f) || fabsf(want) > 0.4f * size || c.y < 0.1f + size || c.y > 0.9f - size)
                continue;
            cut++;
            worst = fmax(worst, fabs(d.psi - want) / size);
        }
        off += grid_count(&g, l);
    }
    printf("# MIP edge: %d coarser cells cut by the edge, worst psi error %.3f cell sizes\n", cut, worst);
    CHECK("MIP levels keep where the surface ends (psi within 0.02 cell)", cut > 0 && worst < 0.02);
    free(recs);
    grid_free(&g);
    mesh_free(&me);
}

/* The stencil tests' scene: two tilted plates, a steep wall across every z (so that at 160^3 occupied
 * pairs of cells straddle two 64-cell words) and a small box, in the unit cube. */
static void stencil_mesh(mesh *me)
{
    memset(me, 0, sizeof *me);
    mesh_add_quad(me, v3(0.1f, 0.1f, 0.2f), v3(0.9f, 0.1f, 0.35f), v3(0.9f, 0.9f, 0.3f), v3(0.1f, 0.9f, 0.2f), 0);
    mesh_add_quad(me, v3(0.2f, 0.1f, 0.9f), v3(0.2f, 0.8f, 0.6f), v3(0.3f, 0.8f, 0.5f), v3(0.3f, 0.1f, 0.8f), 0);
    mesh_add_quad(me, v3(0.6f, 0.6f, 0.7f), v3(0.7f, 0.6f, 0.7f), v3(0.7f, 0.7f, 0.7f), v3(0.6f, 0.7f, 0.7f), 0);
    mesh_add_quad(me, v3(0.5f, 0.1f, 0.02f), v3(0.5f, 0.9f, 0.02f), v3(0.55f, 0.9f, 0.98f), v3(0.55f, 0.1f, 0.98f), 0);
    mesh_add_flat_triangle(me, v3(0, 0, 0), v3(0.001f, 0, 0), v3(0, 0.001f, 0), 0);
    mesh_add_flat_triangle(me, v3(1, 1, 1), v3(0.999f, 1, 1), v3(1, 0.999f, 1), 0);
}

/* hn_fill_stencil, which looks up the coarser level first and stops when its cells are all empty,
 * against grid_index cell by cell: a grid of stencil_mesh's scene, 20,000 random
 * points in and around it at random fractional levels. Where it reports nothing, every one of the
 * 16 cells is empty; elsewhere every entry (slot, record index) is the cell's; and it does stop
 * early for some points (the case it exists for). At 32^3 a column is one word of 64 cells; at
 * 160^3 it is three: half the points there lie by a steep wall where the finer cells straddle two
 * words (hn_column_pair then reads both), and those are counted. */
static void stencil_brute_force(int res)
{
    mesh me;
    stencil_mesh(&me);
    voxel_grid g;
    vx_err e;
    if (grid_build(&g, &me, res, &e)) {
        CHECK("grid builds (stencils)", 0);
        mesh_free(&me);
        return;
    }
    uint64_t seed = 3;
    int wrong = 0, stopped = 0, full = 0, straddle = 0;
    for (int t = 0; t < 20000; t++) {
        vec3 p = v3((float)(1.4 * rnd01(&seed) - 0.2), (float)(1.4 * rnd01(&seed) - 0.2), (float)(1.4 * rnd01(&seed) - 0.2));
        float level = (float)(rnd01(&seed) * (g.levels + 0.5) - 0.5);
        if (res > 64 && (t & 1)) {
            /* by the wall, at level 0 or 1, where the finer 2x2x2 block's z cells are 63 and 64 */
            int L = (int)(2.0 * rnd01(&seed));
            level = (float)L + 0.25f * (float)rnd01(&seed);
            p.x = (float)(0.49 + 0.08 * rnd01(&seed));
            p.z = (float)(g.origin_d[2] + (63.5 + rnd01(&seed)) * (double)(1 << L) * g.voxel_size_d);
        }
        hn_stencil st;
        int any = hn_fill_stencil(&g, p, level, &st);
        float lv = fminf(fmaxf(level, 0.0f), (float)(g.levels - 1));
        int L0 = (int)floorf(lv), L1 = L0 + 1 < g.levels ? L0 + 1 : L0;
        double lat[3];
        grid_to_lattice(&g, p, lat);
        long want[16];
        int n = 0, nonempty = 0;
        for (int L = L0; L <= L1 && n < 16; L++) {
            size_t off = 0;
            for (int l = 0; l < L; l++)
                off += grid_count(&g, l);
            int i0[3];
            for (int a = 0; a < 3; a++)
                i0[a] = (int)floor(lat[a] / (double)(1 << L) - 0.5);
            straddle += i0[2] >= 0 && (i0[2] & 63) == 63 && i0[2] + 1 < g.level[L].n && any;
            for (int dx = 0; dx < 2; dx++)
                for (int dy = 0; dy < 2; dy++)
                    for (int dz = 0; dz < 2; dz++) {
                        int64_t idx = grid_index(&g, L, i0[0] + dx, i0[1] + dy, i0[2] + dz);
                        want[n++] = idx < 0 ? -1L : (long)(off + (size_t)idx);
                        nonempty += idx >= 0;
                    }
        }
        if (!any) {
            stopped += st.count == 0;
            wrong += nonempty != 0;
            continue;
        }
        full++;
        wrong += st.count != n;
        for (int i = 0; i < n && i < st.count; i++)
            wrong += st.index[i] != want[i] || st.slot[i] != (i >= 8);
    }
    printf("# stencils at %d^3: %d of 20000 with surface, %d empty ones stopped at the coarser level, %d straddling "
           "two words, %d wrong\n", res, full, stopped, straddle, wrong);
    CHECK("stencils agree with grid_index cell by cell, empty ones found empty", wrong == 0 && full > 1000);
    CHECK("an empty coarser level ends the lookup", stopped > 1000);
    if (res > 64)
        CHECK("some stencils' column pairs straddle two words", straddle > 20);
    grid_free(&g);
    mesh_free(&me);
}

/* The per-cell definitions the blends had before they took a cell's weights per level block and
 * axis row (hn_stencil's layout), kept here as the reference: the edge field's weights, gradients
 * and offsets, and the attributes' bilinear factors; and the geometry blend's weights of level k
 * summed over every entry of slot k (it now visits block k only; stencil_brute_force checks that
 * block k is slot k). */
static void ref_edge_terms(const hn_stencil *st, int i, vec3 p, float *w, vec3 *gw, vec3 *dp)
{
    float size = st->size[i];
    *dp = v3_sub(p, st->centre[i]);
    float wa[3], ga[3];
    for (int a = 0; a < 3; a++) {
        float u = v3_get(*dp, a) / size;
        wa[a] = vx_fmaxf(0.0f, 1.0f - fabsf(u));
        ga[a] = (u > 0.0f ? -1.0f : 1.0f) / size;
    }
    *w = wa[0] * wa[1] * wa[2];
    *gw = v3(ga[0] * wa[1] * wa[2], wa[0] * ga[1] * wa[2], wa[0] * wa[1] * ga[2]);
}

static int ref_blend_edge(const hn_record *records, const hn_stencil *st, vec3 p, hn_sample *s)
{
    vec3 N = v3_normalize_or(s->n, v3(0.0f, 0.0f, 1.0f));
    int count = st->count < HN_STENCIL_MAX ? st->count : HN_STENCIL_MAX;
    hn_edge_sums sums;
    hn_edge_sums_zero(&sums);
    hn_edge_cells cells;
    hn_edge_cells_decode(records, st, count, N, &cells);
    for (int i = 0; i < count; i++) {
        float w, psi;
        vec3 gw, dp;
        ref_edge_terms(st, i, p, &w, &gw, &dp);
        if (st->index[i] >= 0) {
            if (!cells.own[i])
                continue;
            psi = cells.psi[i];
        } else {
            if (!hn_edge_empty_counts(st, i, count, &cells, N, s->D, dp))
                continue;
            psi = 0.5f * st->size[i];
        }
        hn_edge_sums_add(&sums, st->slot[i] ? 1 : 0, w, gw, psi);
    }
    return hn_edge_finish(st->level_frac, &sums, s); /* the levels mixed as the model mixes them */
}

/* The attributes' area weights of entry i (the bilinear factors along the surface, per cell). */
static float ref_attribute_weight(const hn_stencil *st, int i, vec3 p, int across, float area)
{
    float wa = area / (st->size[i] * st->size[i]);
    for (int a = 0; a < 3; a++)
        if (a != across)
            wa *= vx_fmaxf(0.0f, 1.0f - fabsf(v3_get(p, a) - v3_get(st->centre[i], a)) / st->size[i]);
    return wa;
}

static int same_float(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }
static int same_vec(vec3 a, vec3 b) { return same_float(a.x, b.x) && same_float(a.y, b.y) && same_float(a.z, b.z); }

/* hn_element_edge as it was defined before it tried the foot first: the centre's field blended,
 * then the foot's read over it where the foot has one (a mutation of the new order must differ from
 * this on the stencils of stencil_blends_per_cell). *kept: whether the foot's field was kept. */
static int ref_element_edge(const voxel_grid *g, const hn_record *records, const hn_stencil *st, vec3 p, float level,
                            hn_sample *s, hn_stencil *sts, int *kept)
{
    hn_blend_edge(records, st, p, s);
    int foot_filled = 0;
    *kept = 0;
    if (sqrtf(v3_dot(s->n, s->n)) > HN_FLAT_COHERENCE && st->count == HN_STENCIL_MAX) {
        hn_sample sf = *s;
        vec3 foot = v3_madd(p, v3_normalize_or(s->n, v3(0.0f, 0.0f, 1.0f)), -s->D);
        foot_filled = fabsf(s->D) < 1e30f;
        if (foot_filled && hn_fill_stencil(g, foot, level, sts)) {
            sf.D = 0.0f;
            if (hn_blend_edge(records, sts, foot, &sf)) {
                s->psi = sf.psi;
                s->gpsi = sf.gpsi;
                s->edge = sf.edge;
                *kept = 1;
            }
        }
    }
    return foot_filled;
}

/* hn_blend_edge's and hn_blend_attributes's per-level-block forms, and hn_blend_level_geometry's
 * weights, against the per-cell definitions above, bit for bit: stencils of a 32^3 grid of stencil_mesh's scene
 * (hn_fill_stencil, as in stencil_brute_force) at 20,000 random points and levels, every record
 * random (normals, heights, variances, areas, psi, sidedness, colours), each blend asked at the
 * point and, for the edge, at random planes through it. */
static void stencil_blends_per_cell(void)
{
    mesh me;
    stencil_mesh(&me);
    voxel_grid g;
    vx_err e;
    if (grid_build(&g, &me, 32, &e)) {
        CHECK("grid builds (blends)", 0);
        mesh_free(&me);
        return;
    }
    size_t total = bake_record_count(model_find("heitz-neyret"), &g); /* every level's records */
    hn_record *recs = calloc(total, sizeof *recs);
    uint64_t seed = 11;
    for (size_t i = 0; i < total; i++) {
        hn_record *r = &recs[i];
        r->h = (float)(rnd01(&seed) - 0.5) * 0.05f;
        for (int a = 0; a < 3; a++) {
            r->n[a] = (short)(65534.0 * rnd01(&seed) - 32767.0);
            r->a[a] = (unsigned char)(256.0 * rnd01(&seed));
            r->as[a] = (signed char)(254.0 * rnd01(&seed) - 127.0);
        }
        r->var_h = hn_float_to_half((float)rnd01(&seed) * 0.1f);
        r->var_n = hn_float_to_half((float)rnd01(&seed) * 0.5f);
        /* a tenth never hit (area 0), a tenth hit only from behind (negative: no colour) */
        double u = rnd01(&seed);
        r->area = hn_float_to_half(u < 0.1 ? 0.0f : (float)(u < 0.2 ? -rnd01(&seed) : rnd01(&seed)));
        r->alpha = (unsigned short)(65536.0 * rnd01(&seed));
        r->f0_flags = (unsigned char)((rnd01(&seed) < 0.3 ? HN_TWO_SIDED : 0u) | (unsigned)(128.0 * rnd01(&seed)));
        r->psi = (signed char)(254.0 * rnd01(&seed) - 127.0);
    }
    int wrong = 0, edges = 0, blocks16 = 0, feet_kept = 0, feet_missed = 0;
    for (int t = 0; t < 20000; t++) {
        vec3 p = v3((float)(1.4 * rnd01(&seed) - 0.2), (float)(1.4 * rnd01(&seed) - 0.2), (float)(1.4 * rnd01(&seed) - 0.2));
        float level = (float)(rnd01(&seed) * (g.levels + 0.5) - 0.5);
        hn_stencil st;
        if (!hn_fill_stencil(&g, p, level, &st))
            continue;
        blocks16 += st.count == 16;
        int count = st.count;
        /* the geometry's weights of level k: those of the entries of slot k, summed in entry order */
        for (int k = 0; k < 2; k++) {
            float want = 0.0f;
            for (int i = 0; i < count; i++) {
                hn_data d;
                if ((st.slot[i] ? 1 : 0) != k || !(st.weight[i] > 0.0f) || st.index[i] < 0)
                    continue;
                hn_decode_geometry(recs + st.index[i], st.size[i], &d);
                if (d.area > 0.0f)
                    want += st.weight[i] * vx_fminf(1.0f, 2.0f * d.area / (st.size[i] * st.size[i]));
            }
            hn_sample gk;
            wrong += !same_float(hn_blend_level_geometry(recs, &st, count, k, p, &gk), want);
        }
        /* the edge, from the blended geometry and from a random plane through p */
        hn_sample s0;
        hn_sample_zero(&s0);
        int have = hn_blend_geometry(recs, &st, p, &s0);
        for (int plane = 0; plane < 2; plane++) {
            hn_sample a = s0;
            if (plane || !have) {
                hn_sample_zero(&a);
                a.n = v3((float)rnd_gauss(&seed), (float)rnd_gauss(&seed), (float)rnd_gauss(&seed));
                a.D = (float)(rnd01(&seed) - 0.5) * st.size[0];
            }
            hn_sample b = a;
            int ra = hn_blend_edge(recs, &st, p, &a), rb = ref_blend_edge(recs, &st, p, &b);
            edges += a.edge;
            wrong += ra != rb || a.edge != b.edge || !same_float(a.psi, b.psi) || !same_vec(a.gpsi, b.gpsi);
        }
        /* the element's edge (hn_element_edge, the foot tried first) against the centre's field
         * blended first: from the blended geometry, and from a random unit plane through p, whose
         * normal is long enough for the foot's read */
        for (int plane = 0; plane < 2; plane++) {
            hn_sample a = s0;
            if (plane || !have) {
                hn_sample_zero(&a);
                a.n = v3_normalize_or(v3((float)rnd_gauss(&seed), (float)rnd_gauss(&seed), (float)rnd_gauss(&seed)),
                                      v3(0.0f, 0.0f, 1.0f));
                a.D = (float)(rnd01(&seed) - 0.5) * st.size[0];
            }
            hn_sample b = a;
            hn_stencil sa, sb;
            int kept, fa = hn_element_edge(&g, recs, &st, p, level, &a, &sa),
                      fb = ref_element_edge(&g, recs, &st, p, level, &b, &sb, &kept);
            wrong += fa != fb || a.edge != b.edge || !same_float(a.psi, b.psi) || !same_vec(a.gpsi, b.gpsi);
            if (fa) { /* the foot's stencil, which the attributes read: the same cells */
                wrong += sa.count != sb.count;
                for (int i = 0; i < sa.count && i < HN_STENCIL_MAX; i++)
                    wrong += sa.index[i] != sb.index[i];
                /* the foot's field kept (its finer level has cells), or p's blended after it */
                feet_kept += kept;
                feet_missed += !kept;
            }
        }
        /* the attributes' weights, entry by entry, and the whole blend against them summed per cell */
        vec3 n = v3((float)rnd_gauss(&seed), (float)rnd_gauss(&seed), (float)rnd_gauss(&seed));
        hn_sample at;
        hn_sample_zero(&at);
        hn_blend_attributes(recs, &st, p, n, &at);
        float ax = fabsf(n.x), ay = fabsf(n.y), az = fabsf(n.z);
        int across = ax >= ay && ax >= az ? 0 : (ay >= az ? 1 : 2);
        float wv[2] = {0.0f, 0.0f}, vh[2] = {0.0f, 0.0f};
        for (int i = 0; i < count; i++) {
            if (st.index[i] < 0)
                continue;
            hn_data d;
            hn_decode(recs + st.index[i], st.size[i], &d);
            if (!(d.area > 0.0f))
                continue;
            float w = ref_attribute_weight(&st, i, p, across, d.area);
            if (!(w > 0.0f))
                continue;
            vh[st.slot[i]] += w * d.var_h;
            wv[st.slot[i]] += w;
        }
        float f = vx_fminf(vx_fmaxf(st.level_frac, 0.0f), 1.0f), w0, w1;
        hn_level_weights(f, wv[0] > 0.0f, wv[1] > 0.0f, &w0, &w1);
        if (w0 + w1 > 0.0f) {
            float want = (w0 > 0.0f ? w0 * vh[0] / wv[0] : 0.0f) + (w1 > 0.0f ? w1 * vh[1] / wv[1] : 0.0f);
            want /= w0 + w1;
            wrong += !same_float(want, at.var_h);
        }
    }
    printf("# blends per level block: %d edge fields, %d two-level stencils, element edges read at the foot %d, at "
           "the centre after a foot %d, %d differences from the per-cell forms and the centre-first edge\n",
           edges, blocks16, feet_kept, feet_missed, wrong);
    CHECK("edge, attribute and geometry blends equal their per-cell forms, and the element's edge the centre-first "
          "one, bit for bit",
          wrong == 0 && edges > 5000 && blocks16 > 1000 && feet_kept > 500 && feet_missed > 100);
    free(recs);
    grid_free(&g);
    mesh_free(&me);
}

static void grid_cases(void)
{
    const vx_model *m = model_find("heitz-neyret");
    if (!m)
        return;
    /* A flat square at z = 0.3 inside [0, 1]^2 (mesh bounds), 16^3 grid. */
    mesh me;
    memset(&me, 0, sizeof me);
    mesh_add_quad(&me, v3(0, 0, 0.3f), v3(1, 0, 0.3f), v3(1, 1, 0.3f), v3(0, 1, 0.3f), 0);
    mesh_add_flat_triangle(&me, v3(0, 0, 0), v3(0.001f, 0, 0), v3(0, 0.001f, 0), 0); /* bounds down to z = 0 */
    voxel_grid g;
    vx_err e;
    if (grid_build(&g, &me, 16, &e)) {
        CHECK("grid builds", 0);
        return;
    }
    hn_record *recs = calloc(bake_record_count(m, &g), sizeof *recs);
    /* Level 0 records as the bake would make them: the quad's plane, exactly. */
    for (size_t i = 0; i < grid_count(&g, 0); i++) {
        int x, y, z;
        grid_coords(&g, 0, i, &x, &y, &z);
        vec3 c = grid_cell_center(&g, 0, x, y, z);
        hn_data d;
        memset(&d, 0, sizeof d);
        int on_quad = fabsf(c.z - 0.3f) < g.voxel_size && c.x > 0 && c.x < 1 && c.y > 0 && c.y < 1;
        d.n = v3(0, 0, 1);
        d.h = 0.3f - c.z;
        d.area = on_quad ? g.voxel_size * g.voxel_size : 1e-3f * g.voxel_size * g.voxel_size;
        d.a = v3(0.5f, 0.5f, 0.5f);
        d.has_color = 1;
        hn_encode(&d, g.voxel_size, &recs[i]);
    }
    CHECK("bake_finish succeeds", m->bake_finish(&g, recs, &hn_defaults) == 0);
    /* Every coarser record must describe the same plane: h = 0.3 - centre.z. */
    double worst = 0;
    size_t off = grid_count(&g, 0);
    for (int l = 1; l < g.levels; l++) {
        for (size_t i = 0; i < grid_count(&g, l); i++) {
            int x, y, z;
            grid_coords(&g, l, i, &x, &y, &z);
            vec3 c = grid_cell_center(&g, l, x, y, z);
            hn_data d;
            hn_decode(&recs[off + i], (float)ldexp(g.voxel_size, l), &d);
            if (d.area > 0.01f * (float)ldexp(g.voxel_size, 2 * l))
                worst = fmax(worst, fabs(d.h - (0.3 - c.z)) / ldexp(g.voxel_size, l));
        }
        off += grid_count(&g, l);
    }
    printf("# MIP: worst plane height error %.2e cell sizes\n", worst);
    CHECK("MIP levels keep the plane (height within 0.1 cell)", worst < 0.1);
    /* Cone elements at every level, including wider than the grid, and far outside it. */
    float levels[] = {0.0f, 0.5f, 1.0f, 2.7f, (float)(g.levels - 1), 40.0f, -3.0f, NAN};
    /* Just below the plane (a tenth of a voxel: inside the layer a crossing ray reaches), well
     * above it, and deep below it (6 voxels: a solid's surface is a layer, not the half-space). */
    float vs = (float)g.voxel_size;
    vec3 points[] = {v3(0.5f, 0.5f, 0.3f), v3(0.5f, 0.5f, 0.3f - 0.1f * vs), v3(0.5f, 0.5f, 0.9f), v3(0.01f, 0.99f, 0.3f),
                     v3(100.0f, -50.0f, 3.0f), v3(NAN, 0.5f, 0.3f), v3(0.5f, 0.5f, 0.3f - 6.0f * vs)};
    int ok = 1, covered_below = 1, empty_above = 1, empty_deep = 1;
    for (size_t li = 0; li < sizeof levels / sizeof levels[0]; li++)
        for (size_t pi = 0; pi < sizeof points / sizeof points[0]; pi++) {
            vx_query q;
            memset(&q, 0, sizeof q);
            q.grid = &g;
            q.records = recs;
            q.table = hn_mask_table(); /* as both backends hand it over (vx_cone_eval.table) */
            q.position = points[pi];
            q.level = levels[li];
            q.footprint = isfinite(levels[li]) ? 0.5f * g.voxel_size * exp2f(fminf(fmaxf(levels[li], 0.0f), 40.0f)) : 1.0f;
            q.ray_dir = v3_normalize(v3(0.2f, 0.1f, -1.0f));
            q.to_viewer = v3_scale(q.ray_dir, -1.0f);
            q.light_count = 1;
            q.to_light[0] = v3(0, 0, 1);
            q.irradiance[0] = v3(1, 1, 1);
            q.effects = VX_EFFECT_SHADOWS | VX_EFFECT_SPECULAR;
            vx_answer a;
            m->cone->element.fn(&q, &a);
            ok &= finite3(a.radiance) && a.radiance.x >= 0 && isfinite(a.opacity) && a.opacity >= 0 && a.opacity <= 1;
            if (pi == 1 && li <= 1)
                covered_below &= a.opacity == 1.0f;
            if (pi == 2 && li <= 1)
                empty_above &= a.opacity == 0.0f;
            if (pi == 6 && li <= 1)
                empty_deep &= a.opacity == 0.0f;
        }
    CHECK("cone elements at every level (wider than the grid, NaN, far away): finite, in range", ok);
    CHECK("element below the plane is covered", covered_below);
    CHECK("element well above the plane is empty", empty_above);
    CHECK("element deep below the plane is empty (the surface's layer, not its half-space)", empty_deep);
    /* Without a grid (the hard-case table's queries): nothing, not a crash. */
    vx_query q;
    memset(&q, 0, sizeof q);
    vx_answer a;
    m->cone->element.fn(&q, &a);
    CHECK("cone element without a grid answers nothing", a.opacity == 0.0f && hn_mask_count(a.mask) == 0);
    free(recs);
    grid_free(&g);
    mesh_free(&me);
}

static int print_lambda(int argc, char **argv)
{
    for (int i = 2; i < argc; i++) {
        float c, s;
        if (sscanf(argv[i], "%f,%f", &c, &s) != 2)
            return 1;
        printf("%.9g %.9g %.9g\n", c, s, hn_lambda(c, s));
    }
    return 0;
}

/* The portable atan2, log and erfc (hn_fastmath.h) against double precision, over their ranges. */
static void fastmath(void)
{
    double worst_atan = 0, worst_log = 0, worst_erfc = 0, worst_erfcx = 0;
    for (int i = 0; i < 4000; i++) {
        double t = 2.0 * M_PI * i / 4000.0;
        for (int k = 0; k < 3; k++) {
            double r = k == 0 ? 1e-3 : (k == 1 ? 1.0 : 1e4);
            float y = (float)(r * sin(t)), x = (float)(r * cos(t));
            double d = fabs(hn_atan2f(y, x) - atan2((double)y, (double)x));
            worst_atan = fmax(worst_atan, fmin(d, fabs(d - 2.0 * M_PI))); /* -pi and pi are one angle */
        }
    }
    for (int i = 0; i <= 4000; i++) {
        float x = (float)pow(10.0, -37.0 + 75.0 * i / 4000.0);
        worst_log = fmax(worst_log, fabs(hn_logf(x) - log((double)x)) / fmax(1.0, fabs(log((double)x))));
        float z = (float)(-4.0 + 14.0 * i / 4000.0); /* erfc from 2 down to 1e-44 */
        double want = erfc((double)z);
        /* The float exponent -z^2 carries a relative error of 6e-8 z^2 into the result: below 2e-6
         * up to z = 4 (Lambda uses erfc below 2), 1e-5 at z = 10 (erfc 2e-45, for g(h)'s tail). */
        if (want > 1e-37)
            worst_erfc = fmax(worst_erfc, fabs(hn_erfcf(z) - want) / want / (z > 4.0f ? 5.0 : 1.0));
        float y = (float)(20.0 * i / 4000.0);
        double wx = y < 25.0 ? exp((double)y * y) * erfc((double)y) : 0.0;
        worst_erfcx = fmax(worst_erfcx, fabs(hn_erfcxf(y) - wx) / wx);
    }
    printf("# fastmath worst: atan2 %.3g rad, log %.3g, erfc %.3g rel, erfcx %.3g rel\n", worst_atan, worst_log,
           worst_erfc, worst_erfcx);
    CHECK("portable atan2 within 5e-7 rad", worst_atan < 5e-7);
    CHECK("portable log within 3e-7 relative", worst_log < 3e-7);
    CHECK("portable erfc within 2e-6 relative to z = 4, 1e-5 beyond", worst_erfc < 2e-6);
    CHECK("portable erfcx within 2e-6 relative", worst_erfcx < 2e-6);
    CHECK("portable atan2 at the origin and on the axes",
          hn_atan2f(0.0f, 0.0f) == 0.0f && fabsf(hn_atan2f(1.0f, 0.0f) - 1.5707963f) < 2e-7f &&
              fabsf(hn_atan2f(0.0f, -1.0f) - 3.1415927f) < 3e-7f && hn_atan2f(0.0f, 1.0f) == 0.0f);
    CHECK("portable erfc at the ends", hn_erfcf(INFINITY) == 0.0f && hn_erfcf(-INFINITY) == 2.0f && isnan(hn_erfcf(NAN)));
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "--lambda") == 0)
        return print_lambda(argc, argv);
    bake_params_defaults(model_find("heitz-neyret"), &hn_defaults);
    element_table();
    scalar_table();
    fastmath();
    mask_provenance();
    masks();
    bake();
    grid_cases();
    stencil_brute_force(32);
    stencil_brute_force(160);
    stencil_blends_per_cell();
    mip_edge();
    return unit_exit();
}
