/* The primary rays' empty-space skip (see pixel_skip.h). */
#include "pixel_skip.h"

#include <math.h>

#include "vec_d.h"

float pixel_skip_t(const grid_distance *s, vec3 org, const vec3 *dir, int count)
{
    if (!s || !s->dist || count < 1)
        return 0.0f;
    const double o[3] = {org.x, org.y, org.z};
    const double d0[3] = {dir[0].x, dir[0].y, dir[0].z};
    if (!(isfinite(o[0]) && isfinite(o[1]) && isfinite(o[2]) && isfinite(d0[0]) && isfinite(d0[1]) &&
          isfinite(d0[2])))
        return 0.0f;
    /* spread: how far apart (max norm) two rays of the group get per unit of t; speed: how far the
     * first ray moves per unit of t. */
    double spread = 0.0, speed = 0.0, t_lo = INFINITY, t_hi = 0.0;
    /* A margin far above the rounding of these doubles and of the DDA's own (relative 1e-16 of the
     * coordinates; a thousandth of a block here). The box is widened by it, so that a ray grazing
     * the grid counts as entering it, no later than its DDA does. */
    const double margin = 1e-3 * s->block;
    const double box_lo[3] = {s->lo[0] - margin, s->lo[1] - margin, s->lo[2] - margin};
    const double box_hi[3] = {s->hi[0] + margin, s->hi[1] + margin, s->hi[2] + margin};
    for (int i = 0; i < count; i++) {
        const double di[3] = {dir[i].x, dir[i].y, dir[i].z};
        for (int a = 0; a < 3; a++) {
            double e = fabs(di[a] - d0[a]);
            if (!(e <= 1e30)) /* NaN or huge: no skip */
                return 0.0f;
            spread = e > spread ? e : spread;
        }
        double a, b;
        if (vx_ray_box(o, di, box_lo, box_hi, 0.0, &a, &b)) {
            t_lo = a < t_lo ? a : t_lo;
            t_hi = b > t_hi ? b : t_hi;
        }
    }
    if (!(t_lo < INFINITY))
        return 0.0f; /* every ray misses the grid: the DDA rejects them at once */
    for (int a = 0; a < 3; a++)
        speed = fabs(d0[a]) > speed ? fabs(d0[a]) : speed;
    if (!(speed > 0.0))
        return 0.0f;
    const int n = s->n;
    /* The block of a point: by a multiplication (a point rounded into the next block is still within
     * a rounding error of its own, far inside the margin). */
    const double inv_block = 1.0 / s->block, min_step = 0.25 * s->block / (spread + speed);
    double t = t_lo, verified = t_lo; /* [0, verified]: no ray of the group meets a non-empty voxel */
    for (int iter = 0; iter < 4 * GRID_DISTANCE_MAX_N && t < t_hi; iter++) {
        /* The first ray's point, brought into the grid's box (out: how far it was outside). */
        double out = 0.0;
        int b[3];
        for (int a = 0; a < 3; a++) {
            double p = o[a] + t * d0[a], c = p < s->lo[a] ? s->lo[a] : (p > s->hi[a] ? s->hi[a] : p);
            double e = fabs(p - c);
            out = e > out ? e : out;
            int f = (int)((c - s->lo[a]) * inv_block); /* c >= lo: truncation is floor */
            b[a] = f > n - 1 ? n - 1 : f;
        }
        int D = grid_distance_at(s, b[0], b[1], b[2]);
        /* Empty: every point within (D - 1) blocks (max norm) of the box point c, which lies in block b.
         * Over [t, t + step] every ray of the group stays within t' * spread of the first ray, which
         * moves step * speed from p, itself `out` from c: all inside that cube when the sum is at most
         * R. */
        double R = (double)(D - 1) * s->block - margin;
        double step = (R - out - t * spread) / (spread + speed);
        if (!(step > min_step))
            break; /* too close to a non-empty block (or to the spread's limit): the DDA goes on */
        t += step;
        verified = t;
    }
    if (verified >= t_hi)
        verified = t_hi; /* past every ray's exit: each DDA finds nothing */
    float f = (float)verified;
    if ((double)f > verified)
        f = nextafterf(f, 0.0f);
    return f > 0.0f ? f : 0.0f;
}
