/* Heitz & Neyret 2012: the closed forms of the Gaussian microsurface (Smith 1967) that the model
 * evaluates per cone element. Portable C: no libc beyond <math.h>, so it also compiles as OpenCL C.
 *
 * Conventions: sigma is the per-axis standard deviation of the geometric slopes (isotropic), and
 * directions are given by their cosine to the mean normal. Every function is finite for every
 * input (cosines outside [0, 1], sigma = 0, sigma huge): the cone tracer calls them on
 * interpolated data, where the mean normal may face away or vanish. */
#ifndef VX_HN_MATH_H
#define VX_HN_MATH_H

#include "hn_fastmath.h"
#include "portable_hints.h"
#include "shading.h"

#define HN_SQRT_PI 1.77245385090551602730f
/* Slope deviations past this are vertical walls for every purpose; clamping keeps sigma^2 finite. */
#define HN_SIGMA_MAX 1e6f
#define HN_SQRT2 1.41421356237309504880f

/* The tail of Laplace's continued fraction for erfc: erfc(x) = e^(-x^2)/sqrt(pi) / (x + K(x)),
 * K(x) = (1/2)/(x + 1/(x + (3/2)/(x + ...))). For x >= 2, 24 terms give K to float precision.
 * Why it is needed: Lambda = (e^(-x^2)/(x sqrt(pi)) - erfc(x)) / 2 cancels catastrophically in the
 * tail (both terms agree to 1 / (2 x^2)), while the continued fraction gives the difference
 * directly as K / (x (x + K)).
 * Evaluated forward (Wallis' recurrence for the numerator A and denominator B of the truncated
 * fraction) rather than from its last term back: one division instead of 24 chained ones, the
 * marcher's longest latency chain. Scaled by x: K = G / (2 x) with G = 1/(1 + c_2/(1 + c_3/(1 + ...))),
 * c_k = k / (2 x^2), so that B grows at most 2.3-fold a term (c_k <= 3 for x >= 2) and never
 * overflows. G is near 1 for large x, so the recurrence carries D = A - B (the same recurrence)
 * rather than A: the rounding of each step then stays relative to the small D, and K is within
 * 2e-7 relative of the exact fraction for every x >= 2 (the backward form: 1e-7; carrying A:
 * 8e-7). Every term is positive: no cancellation in B. */
VX_INLINE float hn_erfc_cf_tail(float x)
{
    float t = 0.5f / (x * x);
    /* D and B of the last two convergents: 0 / 1 (D = -1), then G's first, 1 / 1 (D = 0). */
    float d0 = -1.0f, d1 = 0.0f, b0 = 1.0f, b1 = 1.0f;
    for (int k = 2; k <= 24; k++) {
        float c = (float)k * t;
        float d = d1 + c * d0, b = b1 + c * b0;
        d0 = d1;
        d1 = d;
        b0 = b1;
        b1 = b;
    }
    return 0.5f * (b1 + d1) / (b1 * x);
}

/* sqrt(pi) * erfcx(y) = sqrt(pi) e^(y^2) erfc(y) for y >= 0, without overflow for large y. */
VX_INLINE float hn_sqrtpi_erfcx(float y)
{
    y = vx_fmaxf(y, 0.0f);
    if (y < 2.0f)
        return HN_SQRT_PI * hn_erfcxf(y);
    return 1.0f / (y + hn_erfc_cf_tail(y));
}

/* Standard normal CDF and density. */
VX_INLINE float hn_phi_cdf(float x) { return 0.5f * hn_erfcf(-x / HN_SQRT2); }
VX_INLINE float hn_phi_pdf(float x) { return 0.39894228040143267794f * expf(-0.5f * x * x); }

/* cot(theta) from cos(theta), clamped to [1e-6, 1e6]: grazing views stay finite, normal incidence
 * gives a huge cotangent (Lambda = 0). Directions behind the mean plane count as grazing. */
VX_INLINE float hn_cot_from_cos(float c)
{
    c = vx_fminf(vx_fmaxf(c, 0.0f), 1.0f);
    float s = sqrtf((1.0f - c) * (1.0f + c)); /* (1-c)(1+c): no cancellation near c = 1 */
    if (s < 1e-6f)
        return 1e6f;
    return vx_fmaxf(c / s, 1e-6f);
}

/* Smith's Lambda for Gaussian slopes (2012 paper eq. 6): with mu = cot(theta), x = mu/(sqrt2 sigma),
 * Lambda = (sqrt(2/pi) (sigma/mu) e^(-x^2) - erfc(x)) / 2 = (e^(-x^2)/(x sqrt(pi)) - erfc(x)) / 2.
 * Relative accuracy about 1e-6 everywhere (direct formula for x < 2, continued fraction beyond). */
VX_INLINE float hn_lambda_mu(float mu, float sigma)
{
    if (!(sigma > 1e-12f))
        return 0.0f; /* a flat surface masks nothing */
    sigma = vx_fminf(sigma, HN_SIGMA_MAX);
    mu = vx_fmaxf(mu, 1e-6f);
    float x = mu / (HN_SQRT2 * sigma);
    if (!(x < 9.5f))
        return 0.0f; /* e^(-x^2) < 1e-39: below float */
    if (x < 2.0f)
        return vx_fmaxf(0.0f, 0.5f * (expf(-x * x) / (x * HN_SQRT_PI) - hn_erfcf(x)));
    float k = hn_erfc_cf_tail(x);
    return 0.5f * (expf(-x * x) / HN_SQRT_PI) * k / (x * (x + k));
}

VX_INLINE float hn_lambda(float cos_theta, float sigma)
{
    return hn_lambda_mu(hn_cot_from_cos(cos_theta), sigma);
}

/* g(h) = 1 - erfc(h / (sqrt2 sigma_h)) / 2, the height CDF; s(h) = 2 g(h) - 1. sigma_h = 0 makes g
 * a step (1/2 exactly at h = 0). */
VX_INLINE float hn_g(float h, float sigma_h)
{
    if (!(sigma_h > 0.0f))
        return h > 0.0f ? 1.0f : (h < 0.0f ? 0.0f : 0.5f);
    return 1.0f - 0.5f * hn_erfcf(h / (HN_SQRT2 * sigma_h));
}

/* View- and light-dependent mean visible attribute (2012 paper eq. 17):
 * a(v,l) = a + a_s (2 (Lv + Ll + 1)/(Lv + Ll + 2) - 1) = a + a_s (Lv + Ll)/(Lv + Ll + 2). */
VX_INLINE float hn_attribute(float a_mean, float a_s, float lambda_v, float lambda_l)
{
    float L = vx_fmaxf(lambda_v, 0.0f) + vx_fmaxf(lambda_l, 0.0f);
    float w = L < 1e30f ? L / (L + 2.0f) : 1.0f;
    return a_mean + a_s * w;
}

/* Mean visible depth above the mean plane (2011 report §4.4): 0.39 sigma_h log(1 + 4.75 Lambda(v)),
 * the fitted form (within 14 %) of the integral of h V(v,h) P(h). */
VX_INLINE float hn_visible_depth_offset(float sigma_h, float lambda_v)
{
    return 0.39f * sigma_h * hn_logf(1.0f + 4.75f * vx_fminf(vx_fmaxf(lambda_v, 0.0f), 1e30f));
}

/* Mean of n.N over the projected area of Gaussian slopes, E[1/sqrt(1 + p^2 + q^2)]
 * = sqrt(pi beta) erfcx(sqrt beta), beta = 1 / (2 sigma^2): how much a rough Lambertian surface
 * lit along its mean normal darkens (1 for a flat surface). */
VX_INLINE float hn_lambert_cos_mean(float sigma)
{
    if (!(sigma > 1e-6f))
        return 1.0f;
    sigma = vx_fminf(sigma, HN_SIGMA_MAX);
    float y = 1.0f / (HN_SQRT2 * sigma); /* sqrt(beta) */
    return vx_fminf(1.0f, y * hn_sqrtpi_erfcx(y));
}

/* Tilt of the mean visible normal toward the viewer: the projected-area mean of the visible facets'
 * slope along the view's azimuth, sigma^2 tan(theta) Phi(mu/sigma) / (1 + Lambda(v))
 * = sigma^2 Phi(mu/sigma) / (mu Phi(mu/sigma) + sigma phi(mu/sigma)). Derived from Smith's masking
 * (G1 independent of the facet) and Stein's lemma on the Gaussian slopes; finite at grazing views
 * (about 1.25 sigma) and 0 for a flat surface. */
VX_INLINE float hn_visible_tilt(float mu, float sigma)
{
    if (!(sigma > 1e-8f))
        return 0.0f;
    sigma = vx_fminf(sigma, HN_SIGMA_MAX);
    float z = mu / sigma;
    float P = hn_phi_cdf(z);
    float den = mu * P + sigma * hn_phi_pdf(z);
    return den > 1e-30f ? sigma * sigma * P / den : 0.0f;
}

/* IEEE half -> float without ldexp (a libm call on the hot path). A normal half's float has its
 * mantissa shifted up 13 bits and its exponent rebiased by 127 - 15 = 112: one shift and one add
 * on the bits, and the sign bit moved up 16; the subnormals (m 2^-24) and infinity and NaN (read
 * as 65504, never stored) are picked by selects rather than an if-chain. Three halves a record,
 * up to 48 records a cone element: it took heitz-neyret's frame from 3.73 to 3.70 G instructions
 * (bunny 256^3, callgrind). */
VX_INLINE float hn_half_to_float(unsigned int h)
{
    unsigned int e = (h >> 10) & 31u, m = h & 1023u;
    float normal = VX_BITS_FLOAT(((h & 0x7fffu) << 13) + (112u << 23));
    float v = e == 0u ? (float)m * (1.0f / 16777216.0f) : (e == 31u ? 65504.0f : normal);
    return VX_BITS_FLOAT(VX_FLOAT_BITS(v) | ((h & 0x8000u) << 16));
}

#endif
