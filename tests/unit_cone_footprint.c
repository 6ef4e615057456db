/* The cone marcher's pixel cones (tracer/core/camera.h's camera_cone_spread, which
 * tracer/render/render_cone_core.h gives every pixel's cone on both backends) against the
 * pixels' exact solid angles: for a pinhole camera of 150, 90 and 40 degrees (square and wide
 * images), each pixel's quad on the image plane (the corners camera_ray maps pixel corners to, at
 * unit distance along the axis) subtends a solid angle computed exactly, as two triangles (Van
 * Oosterom & Strackee 1983) in double; the cone of radius r per unit distance subtends
 * 2 pi (1 - 1 / sqrt(1 + r^2)). They must agree within 1 % at the centre, the edges and the corners
 * (a pixel is small: its solid angle varies little across it), where one width for every pixel made
 * a 150-degree view's corner cones 12 times too wide. */
#include <math.h>
#include <stdio.h>

#include "camera.h"
#include "unit.h"

static void plane_point(const camera *c, int w, int h, double x, double y, double p[3])
{
    double aspect = (double)w / (double)h;
    double sx = (2.0 * x / w - 1.0) * c->tan_half_fov_y * aspect, sy = (1.0 - 2.0 * y / h) * c->tan_half_fov_y;
    p[0] = sx, p[1] = sy, p[2] = 1.0; /* the camera's frame: right, up, forward */
}

static double triangle_solid_angle(const double a[3], const double b[3], const double c[3])
{
    double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]),
           lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    double bxc[3] = {b[1] * c[2] - b[2] * c[1], b[2] * c[0] - b[0] * c[2], b[0] * c[1] - b[1] * c[0]};
    double num = fabs(a[0] * bxc[0] + a[1] * bxc[1] + a[2] * bxc[2]);
    double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2], ac = a[0] * c[0] + a[1] * c[1] + a[2] * c[2],
           bc = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
    return 2.0 * atan2(num, la * lb * lc + ab * lc + ac * lb + bc * la);
}

int main(void)
{
    const struct {
        double fov;
        int w, h;
    } views[] = {{150, 96, 96}, {90, 128, 64}, {40, 64, 64}};
    for (size_t v = 0; v < sizeof views / sizeof views[0]; v++) {
        camera c = {0};
        c.tan_half_fov_y = (float)tan(views[v].fov * M_PI / 360.0);
        int w = views[v].w, h = views[v].h;
        float spread = camera_pixel_spread(&c, h);
        const int px[] = {w / 2, 0, w - 1, 0, w / 2, w - 1}, py[] = {h / 2, 0, h - 1, h / 2, 0, h / 3};
        double worst = 0, widest = 0;
        for (size_t i = 0; i < sizeof px / sizeof px[0]; i++) {
            double q[4][3];
            plane_point(&c, w, h, px[i], py[i], q[0]);
            plane_point(&c, w, h, px[i] + 1, py[i], q[1]);
            plane_point(&c, w, h, px[i] + 1, py[i] + 1, q[2]);
            plane_point(&c, w, h, px[i], py[i] + 1, q[3]);
            double exact = triangle_solid_angle(q[0], q[1], q[2]) + triangle_solid_angle(q[0], q[2], q[3]);
            double m[3];
            plane_point(&c, w, h, px[i] + 0.5, py[i] + 0.5, m);
            double cos_axis = 1.0 / sqrt(m[0] * m[0] + m[1] * m[1] + 1.0);
            double r = camera_cone_spread(spread, (float)cos_axis);
            double cone = 2.0 * M_PI * (1.0 - 1.0 / sqrt(1.0 + r * r));
            double rel = fabs(cone / exact - 1.0);
            worst = rel > worst ? rel : worst;
            double axis_r = spread * 1.12837917;
            double wide = 2.0 * M_PI * (1.0 - 1.0 / sqrt(1.0 + axis_r * axis_r)) / exact;
            widest = wide > widest ? wide : widest;
        }
        char name[160];
        snprintf(name, sizeof name,
                 "cone of a pixel = its solid angle within 1 %% (fov %g, %dx%d; worst %.3f %%, one width for all: "
                 "solid angle up to %.1fx)", views[v].fov, w, h, 100 * worst, widest);
        CHECK(name, worst <= 0.01);
    }
    CHECK("on the axis: the disk of the pixel's area, 2/sqrt(pi) x the half-width",
          fabsf(camera_cone_spread(0.01f, 1.0f) - 0.01f * 2.0f / sqrtf((float)M_PI)) <= 1e-8f);
    return unit_exit();
}
