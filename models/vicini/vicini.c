/* `vicini`: the non-exponential transmittance model of Vicini, Jakob and Kaplanyan 2021 as Brito et
 * al. 2023 §5 compare it: per voxel an SGGX distribution of normals, a density and a linear /
 * exponential mix, and one average colour, 11 bytes (vicini_eval.h: the record, the transmittance
 * and the shading). The bake fits the SGGX matrix to the front-facing hit normals (Heitz et al.
 * 2015, the fit vmesh shares) and the density and mix to the sample rays' free flights through the
 * voxel by maximum likelihood (vicini_fit.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "average_bake.h"
#include "average_move.h" /* average_is_identity */
#include "sggx_fit.h"
#include "vicini_eval.h"
#include "vicini_fit.h"

/* The smallest projected area of the SGGX fit (parameter sggx_min_area). Heitz et al.'s SGGX of a
 * flat surface is degenerate (areas 0, 0, 1): a floor keeps S invertible, and it decides how opaque
 * a flat voxel stays when seen edge-on and how far its microflakes spread the shading. The default
 * is the largest floor at which a flat plate still shades as Lambert within 1 % (light 30 degrees
 * off its normal: tests/test_convergence.py's interior shading): at vmesh's 0.1 (the authors'
 * clamp, which only orients its octahedron) a plate comes out 3 % dark. */
#define SGGX_MIN_AREA_DEFAULT 0.05
#define STACK_RAYS 256     /* the default is 150 rays; more than this uses the heap */

/* vicini_params[0]: Brito et al. sample only the voxel's own triangles and keep the flights inside
 * the voxel (0). Vicini et al. extend the rays beyond the voxel so that occlusion correlated across
 * voxels counts (1): here, a hit on the voxel's own triangles outside its box ends the flight at
 * the box's near side (hit before entry) or far side (hit after exit). */
enum { PARAM_EXTENDED = 0, PARAM_MIN_AREA = 1 };

static unsigned char unorm8(float x)
{
    if (!(x > 0.0f))
        return 0;
    return (unsigned char)lroundf(vx_fminf(x, 1.0f) * 255.0f);
}

/* A symmetric S written as Heitz et al.'s six bytes (sqrt of the diagonal over its largest value,
 * and the three correlations). Returns that largest value: the stored S is S / smax^2, so the
 * stored distribution's projected areas are S's over smax, and a density meant for S must be
 * multiplied by smax to keep the same extinction. */
static double encode_sggx_matrix(const double S[3][3], vicini_record *r)
{
    double s[3], smax = 0.0;
    for (int k = 0; k < 3; k++) {
        s[k] = sqrt(vx_fmax(S[k][k], 0.0));
        smax = vx_fmax(smax, s[k]);
    }
    for (int k = 0; k < 3; k++)
        r->sigma[k] = unorm8((float)(s[k] / smax));
    const int pair[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    for (int k = 0; k < 3; k++) {
        double d = s[pair[k][0]] * s[pair[k][1]];
        double c = d > 0.0 ? S[pair[k][0]][pair[k][1]] / d : 0.0;
        r->corr[k] = (unsigned char)lround(vx_fmin(vx_fmax(c, -1.0), 1.0) * 127.0 + 127.0);
    }
    return smax;
}

/* S = R diag(area^2) R^T, written as Heitz et al.'s six bytes. */
static void encode_sggx(const sggx_frame *fr, vicini_record *r)
{
    double S[3][3] = {{0}};
    for (int k = 0; k < 3; k++) {
        double a2 = (double)fr->area[k] * (double)fr->area[k];
        double v[3] = {fr->axis[k].x, fr->axis[k].y, fr->axis[k].z};
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                S[i][j] += a2 * v[i] * v[j];
    }
    encode_sggx_matrix(S, r); /* the density is fitted to the stored S afterwards */
}

static unsigned char encode_density(double rho)
{
    if (!(rho > 0.0))
        return 0;
    double code = 1.0 + 254.0 * log2(rho / VICINI_DENSITY_MIN) / VICINI_DENSITY_LOG2_RANGE;
    return (unsigned char)lround(vx_fmin(vx_fmax(code, 1.0), 255.0));
}

/* The flight of sample s through the voxel (0 when it tells nothing about the voxel's inside). */
static int flight_of(const vx_sample *s, float size, const float S[9], int extended, vicini_flight *f)
{
    float chord = (s->t_exit - s->t_entry) / size;
    if (!(chord > 0.0f))
        return 0;
    float sigma = vicini_sigma(S, s->dir);
    switch (s->kind) {
    case VX_SAMPLE_INSIDE_FRONT:
    case VX_SAMPLE_INSIDE_BACK:
        f->x = sigma * vx_fminf(vx_fmaxf((s->t_hit - s->t_entry) / size, 0.0f), chord);
        f->collided = 1;
        return 1;
    case VX_SAMPLE_OUTSIDE:
        if (s->t_hit <= s->t_entry) { /* stopped before reaching the voxel */
            f->x = 0.0f;
            f->collided = 1;
            return extended;
        }
        f->x = sigma * chord; /* crossed the voxel, met its triangles beyond */
        f->collided = extended;
        return 1;
    default: /* VX_SAMPLE_MISS */
        f->x = sigma * chord;
        f->collided = 0;
        return 1;
    }
}

static void vicini_bake(const vx_voxel *v, const vx_sample *samples, int n, void *out)
{
    vicini_record *r = out;
    vec3 normals_stack[STACK_RAYS];
    vicini_flight flights_stack[STACK_RAYS];
    vec3 *normals = n <= STACK_RAYS ? normals_stack : malloc((size_t)n * sizeof *normals);
    vicini_flight *flights = n <= STACK_RAYS ? flights_stack : malloc((size_t)n * sizeof *flights);
    if (!normals || !flights) { /* out of memory for an oversized sample count: an empty voxel */
        if (normals != normals_stack)
            free(normals);
        if (flights != flights_stack)
            free(flights);
        return;
    }

    float color[3] = {0, 0, 0}, normal[3], specular = 0, roughness = 0;
    unsigned int two_sided;
    average_front_hits(samples, n, color, normal, &specular, &roughness, &two_sided);
    for (int k = 0; k < 3; k++)
        r->color[k] = unorm8(sqrtf(color[k]));
    /* Under `specular`, a rough surface's microflakes spread at least as far as its roughness
     * (Heitz et al. 2015 model a rough surface by an SGGX of that width): the lobe is then the
     * material's, not sharper. Without it, the authors' clamp alone. */
    int shiny = (v->effects & VX_EFFECT_SPECULAR) && specular >= 0.5f * VICINI_SPECULAR_F0;
    float floor_area = v->params ? (float)v->params->value[PARAM_MIN_AREA] : (float)SGGX_MIN_AREA_DEFAULT;
    float min_area = shiny ? vx_fmaxf(floor_area, vx_fminf(roughness, 1.0f)) : floor_area;
    int front = 0;
    for (int i = 0; i < n; i++)
        if (samples[i].kind == VX_SAMPLE_INSIDE_FRONT)
            normals[front++] = vx_sample_front_normal(&samples[i]);
    sggx_frame fr;
    sggx_fit(normals, front, min_area, &fr);
    encode_sggx(&fr, r);

    /* The flights measured with the decoded S: the renderer's sigma(w), so the density fits it. */
    float S[9];
    vicini_decode_sggx(r, S);
    int extended = v->params && v->params->value[PARAM_EXTENDED] > 0.5;
    int m = 0;
    for (int i = 0; i < n; i++)
        m += flight_of(&samples[i], v->size, S, extended, &flights[m]);
    vicini_estimate est;
    double densities[255]; /* what codes 1..255 store: the fit picks among them */
    for (int k = 0; k < 255; k++)
        densities[k] = vicini_decode_density((unsigned)k + 1u);
    vicini_fit(flights, m, densities, 255, &est);
    r->density = encode_density(est.density);
    r->mix = (unsigned char)(lround(vx_fmin(vx_fmax(est.gamma, 0.0), 1.0) * VICINI_GAMMA_MAX_CODE) |
                             (shiny ? VICINI_SPECULAR_BIT : 0u));
    if (normals != normals_stack)
        free(normals);
    if (flights != flights_stack)
        free(flights);
}

static int vicini_validate(const void *record, const vx_record_context *c, char *why, size_t why_size)
{
    (void)c;
    const vicini_record *r = record;
    for (int k = 0; k < 3; k++)
        if (r->corr[k] > VICINI_CORR_MAX_CODE) {
            snprintf(why, why_size, "corr[%d]: code %u (expected 0..%d)", k, r->corr[k], VICINI_CORR_MAX_CODE);
            return -1;
        }
    if (r->sigma[0] == 0 && r->sigma[1] == 0 && r->sigma[2] == 0) { /* the bake normalises to max 1 */
        snprintf(why, why_size, "sigma: all zero (expected the largest at 255)");
        return -1;
    }
    return 0;
}

/* The record's S without the decoder's positivity floor (what encode_sggx_matrix wrote), scaled
 * so that its largest diagonal is 1. */
static void decode_sggx_raw(const vicini_record *r, double S[3][3])
{
    float f[9];
    vicini_decode_sggx(r, f);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            S[i][j] = (double)f[3 * i + j] - (i == j ? 1e-4 : 0.0);
}

/* Rotating the microflakes: S' = R S R^T, re-encoded. The encoding rescales S' to a largest
 * diagonal of 1 (a plate turned 45 degrees has two diagonals of 1/2), so the density takes the
 * scale back: the extinction toward R w is then the record's toward w, up to the six bytes' and
 * the density code's quantisation. Mix and colour do not depend on the direction. */
static void vicini_transform(const void *in, const float R[9], void *out)
{
    vicini_record r = *(const vicini_record *)in;
    if (!average_is_identity(R)) {
        double S[3][3], T[3][3] = {{0}}, U[3][3] = {{0}};
        decode_sggx_raw(&r, S);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                for (int k = 0; k < 3; k++)
                    T[i][j] += (double)R[3 * i + k] * S[k][j];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                for (int k = 0; k < 3; k++)
                    U[i][j] += T[i][k] * (double)R[3 * j + k];
        double smax = encode_sggx_matrix(U, &r);
        r.density = encode_density((double)vicini_decode_density(r.density) * smax);
    }
    *(vicini_record *)out = r;
}

/* Parts put into one voxel: the density is the covered fraction times each part's density, summed
 * (optical mass is conserved through a split); the distribution is the parts' S weighted by that
 * mass (Heitz et al. 2015 mix SGGX distributions linearly, by density; every stored S has a
 * largest diagonal of 1, the scale its density is measured in), re-encoded with the density taking
 * the encoding's scale back; mix, colour and specular bit are the mass-weighted means. */
static void vicini_combine(const vx_record_part *parts, int n, float voxel_size, void *out)
{
    (void)voxel_size; /* nothing in the record is a length */
    if (n == 1 && parts[0].weight == 1.0f) {
        *(vicini_record *)out = *(const vicini_record *)parts[0].record;
        return;
    }
    double mass = 0, plain = 0, S[3][3] = {{0}}, gamma = 0, color[3] = {0, 0, 0}, shiny = 0;
    for (int pass = 0; pass < 2 && !(mass > 0); pass++) /* pass 1: empty parts only, plain weights */
        for (int i = 0; i < n; i++) {
            const vicini_record *a = parts[i].record;
            double w = parts[i].weight * (pass == 0 ? (double)vicini_decode_density(a->density) : 1.0);
            if (pass == 0)
                plain += parts[i].weight * (double)vicini_decode_density(a->density);
            if (!(w > 0))
                continue;
            double Si[3][3];
            decode_sggx_raw(a, Si);
            for (int p = 0; p < 3; p++)
                for (int q = 0; q < 3; q++)
                    S[p][q] += w * Si[p][q];
            gamma += w * vicini_decode_gamma(a->mix);
            for (int k = 0; k < 3; k++) {
                double c = a->color[k] / 255.0;
                color[k] += w * c * c;
            }
            shiny += (a->mix & VICINI_SPECULAR_BIT) ? w : 0.0;
            mass += w;
        }
    vicini_record r;
    memset(&r, 0, sizeof r);
    double scale = 1.0;
    if (mass > 0) {
        for (int p = 0; p < 3; p++)
            for (int q = 0; q < 3; q++)
                S[p][q] /= mass;
        scale = encode_sggx_matrix(S, &r);
        for (int k = 0; k < 3; k++)
            r.color[k] = unorm8((float)sqrt(color[k] / mass));
        r.mix = (unsigned char)(lround(vx_fmin(vx_fmax(gamma / mass, 0.0), 1.0) * VICINI_GAMMA_MAX_CODE) |
                                (2.0 * shiny > mass ? VICINI_SPECULAR_BIT : 0u));
    } else {
        r.sigma[0] = r.sigma[1] = r.sigma[2] = 255; /* an isotropic nothing: valid, never seen */
        r.corr[0] = r.corr[1] = r.corr[2] = 127;
    }
    r.density = encode_density(plain * scale);
    *(vicini_record *)out = r;
}

static const vx_param vicini_params[] = {
    {"extended", 0.0, 0.0, 1.0,
     "1: Vicini et al.'s extended rays (hits on the voxel's triangles outside it end the flight at its side); "
     "0: Brito et al.'s flights inside the voxel",
     .is_switch = 1},
    {"sggx_min_area", SGGX_MIN_AREA_DEFAULT, 0.01, 1.0,
     "floor of the SGGX fit's projected areas: how opaque a flat voxel stays edge-on, how far its shading spreads",
     .is_switch = 0},
    {0},
};

static const vx_voxel_eval vicini_eval = {
    .compositing = VX_COMPOSITE_ALPHA,
    .source = "vicini_eval.h",
    .opacity = VX_PORTABLE(vicini_eval_opacity),
    .shade = VX_PORTABLE(vicini_eval_shade),
    .opacity_by_direction = 1, /* the opacity reads the record and q->ray_dir only (the mean chord) */
    .transmit = VX_PORTABLE(vicini_eval_transmit),
};

const vx_model model_vicini = {
    .abi_version = VX_MODEL_ABI_VERSION,
    .name = "vicini",
    .description = "Vicini et al. 2021 as Brito et al. compare it: SGGX normals, non-exponential transmittance "
                   "(density and linear/exponential mix fitted by maximum likelihood), one colour; 11 bytes",
    .record = {.bytes = sizeof(vicini_record), .layout_version = 1},
    .params = vicini_params,
    .bake_voxel = vicini_bake,
    .validate_record = vicini_validate,
    .voxel = &vicini_eval,
    .transform = vicini_transform,
    .combine = vicini_combine,
};
