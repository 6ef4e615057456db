/* Local shading shared by the ground truth and the voxel models: Lambert diffuse plus, when a scene
 * declares "specular", a Beckmann (Gaussian-slope) microfacet lobe with Smith masking. Beckmann
 * roughness alpha corresponds to a slope variance sigma^2 = alpha^2 / 2 per axis, which is what lets
 * the Heitz–Neyret model add its pre-filtered normal variance to the BRDF's. Portable C: compiles
 * as OpenCL C too. */
#ifndef VX_SHADING_H
#define VX_SHADING_H

#include "vec.h"

#define VX_PI 3.14159265358979323846f

/* Smith's Lambda for a Gaussian slope distribution of per-axis standard deviation sigma, seen at
 * cos_theta from the mean normal: 0.5 * (sqrt(2/pi) * (sigma/mu) * exp(-mu^2 / (2 sigma^2)) -
 * erfc(mu / (sqrt(2) sigma))), mu = cot(theta). Finite for every input: 0 at normal incidence or
 * sigma = 0, large but finite at grazing angles. */
VX_INLINE float shading_smith_lambda(float cos_theta, float sigma)
{
    float c = vx_fminf(vx_fmaxf(cos_theta, 1e-6f), 1.0f);
    if (sigma <= 1e-8f)
        return 0.0f;
    float sin_t = sqrtf(vx_fmaxf(0.0f, 1.0f - c * c));
    float mu = c / vx_fmaxf(sin_t, 1e-7f);
    float x = mu / (1.41421356237f * sigma);
    if (x > 9.0f)
        return 0.0f; /* both terms underflow below 1e-36 */
    float a = 0.79788456080f * (sigma / mu) * expf(-x * x);
    return vx_fmaxf(0.0f, 0.5f * (a - erfcf(x)));
}

/* Beckmann normal distribution D(h) for roughness alpha (RMS slope), cos_h = n.h. */
VX_INLINE float shading_beckmann_d(float cos_h, float alpha)
{
    if (cos_h <= 0.0f)
        return 0.0f;
    float c2 = cos_h * cos_h, a2 = alpha * alpha;
    float tan2 = (1.0f - c2) / c2;
    return expf(-tan2 / a2) / (VX_PI * a2 * c2 * c2);
}

/* Specular BRDF value (without the n.l factor): F D G2 / (4 n.l n.v), with a constant Fresnel
 * reflectance f0 and the height-correlated Smith G2 = 1 / (1 + Lambda(v) + Lambda(l)). */
VX_INLINE float shading_specular_brdf(vec3 n, vec3 v, vec3 l, float f0, float alpha)
{
    float nl = v3_dot(n, l), nv = v3_dot(n, v);
    /* Below the cosine clamp of shading_smith_lambda the masking term no longer cancels the
     * 1 / (n.l n.v) factor; the energy there is negligible. A zero roughness or reflectance (a voxel
     * with no front-facing hit) has no lobe rather than 0/0. */
    if (nl <= 1e-6f || nv <= 1e-6f || !(f0 > 0.0f) || !(alpha > 0.0f))
        return 0.0f;
    vec3 h = v3_normalize(v3_add(v, l));
    float sigma = alpha * 0.70710678f;
    float g2 = 1.0f / (1.0f + shading_smith_lambda(nv, sigma) + shading_smith_lambda(nl, sigma));
    return f0 * shading_beckmann_d(v3_dot(n, h), alpha) * g2 / (4.0f * nl * nv);
}

#endif
