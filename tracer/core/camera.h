/* The camera and its rays: pinhole, or thin lens when a scene declares "dof". Shared by the ground
 * truth, the C voxel tracer and the OpenCL kernel (tracer/backends/opencl/cl/render.cl includes this file; the host
 * copies the scene's camera into its parameter block as it is) so all see exactly the same rays.
 * Portable C: no libc beyond <math.h>, and a layout that C and OpenCL C define alike. */
#ifndef VX_CAMERA_H
#define VX_CAMERA_H

#include "vec.h"

typedef struct {
    vec3 position, forward, right, up; /* orthonormal frame */
    float tan_half_fov_y;
    float aperture_radius; /* thin lens; used only with EFFECT_DOF */
    float focus_distance;
} camera;

#define VX_CAMERA_PI 3.14159265358979323846f

/* Maps two uniform numbers to the unit disk (Shirley–Chiu concentric map: keeps stratification). */
static inline void camera_sample_disk(float u1, float u2, float *dx, float *dy)
{
    float a = 2.0f * u1 - 1.0f, b = 2.0f * u2 - 1.0f;
    if (a == 0.0f && b == 0.0f) {
        *dx = *dy = 0.0f;
        return;
    }
    float r, phi;
    if (fabsf(a) > fabsf(b)) {
        r = a;
        phi = (VX_CAMERA_PI / 4.0f) * (b / a);
    } else {
        r = b;
        phi = (VX_CAMERA_PI / 2.0f) - (VX_CAMERA_PI / 4.0f) * (a / b);
    }
    *dx = r * cosf(phi);
    *dy = r * sinf(phi);
}
/* The ray through image position (x, y) in pixels (0,0 = top-left corner of the image), for lens
 * sample (lu, lv) in [0,1)^2 (ignored without depth of field). */
static inline void camera_ray(const camera *c, int width, int height, float x, float y, float lu, float lv,
                              int dof, vec3 *origin, vec3 *dir)
{
    float aspect = (float)width / (float)height;
    float sx = (2.0f * x / (float)width - 1.0f) * c->tan_half_fov_y * aspect;
    float sy = (1.0f - 2.0f * y / (float)height) * c->tan_half_fov_y;
    vec3 d = v3_add(c->forward, v3_add(v3_scale(c->right, sx), v3_scale(c->up, sy)));
    if (dof && c->aperture_radius > 0.0f) {
        /* d has unit length along forward, so the focus plane point is simply position + d * focus. */
        vec3 focus = v3_madd(c->position, d, c->focus_distance);
        float dx, dy;
        camera_sample_disk(lu, lv, &dx, &dy);
        vec3 o = v3_add(c->position, v3_add(v3_scale(c->right, dx * c->aperture_radius),
                                           v3_scale(c->up, dy * c->aperture_radius)));
        *origin = o;
        *dir = v3_normalize(v3_sub(focus, o));
    } else {
        *origin = c->position;
        *dir = v3_normalize(d);
    }
}

/* Half-angle tangent of a pixel's cone at unit distance (the footprint radius grows by this much per
 * unit of distance along the ray). */
static inline float camera_pixel_spread(const camera *c, int height)
{
    return c->tan_half_fov_y / (float)height;
}

/* The radius per unit distance of the cone of a pixel whose centre ray makes cos_axis with the
 * camera's axis, spread being the half-width of a pixel on the image plane at unit distance along
 * the axis (camera_pixel_spread): the disk of the pixel's solid angle, which matches the ground
 * truth's box filter best. On the axis that is the disk of the pixel's area, 2/sqrt(pi) times the
 * half-width; off it the pixel lies 1/cos farther and is seen at a slant, so its solid angle is
 * cos^3 times the axis pixel's, and the radius cos^1.5 times (the footprint is an ellipse, cos^2
 * across the radial direction and cos along it; a cone is round, so it takes the same area). One
 * width for every pixel made the corner cones of a 150-degree square view 12 times too wide, their
 * MIP levels too coarse, and heitz-neyret's error there stopped falling with resolution (issue 15's
 * audit). */
static inline float camera_cone_spread(float spread, float cos_axis)
{
    float c = vx_fminf(vx_fmaxf(cos_axis, 0.0f), 1.0f);
    return spread * 1.12837917f * c * sqrtf(c);
}

#endif
