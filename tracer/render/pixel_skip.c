/* The primary rays' empty-space skip (see pixel_skip.h): the distance field and the walk. */
#include "pixel_skip.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The finest level with at most PIXEL_SKIP_MAX_N blocks a side: small enough to build in a few
 * milliseconds and to stay in cache, fine enough that the walk stops a few voxels from surfaces. */
static int skip_level(const voxel_grid *g)
{
    for (int k = 0; k < g->levels; k++)
        if (g->level[k].n <= PIXEL_SKIP_MAX_N)
            return k;
    return g->levels - 1;
}

/* One erosion of the empty mask along an axis (3 wide; outside the grid counts as empty), written
 * as AND-ing whole z rows so that the compiler vectorises it (the build then takes a millisecond or
 * two at 64^3 instead of tens). */
static void erode(unsigned char *restrict dst, const unsigned char *restrict src, int n, int axis)
{
    size_t nn = (size_t)n;
    if (axis == 2) {
        for (size_t row = 0; row < nn * nn; row++) {
            const unsigned char *a = src + row * nn;
            unsigned char *b = dst + row * nn;
            b[0] = n > 1 ? (unsigned char)(a[0] & a[1]) : a[0];
            for (size_t z = 1; z + 1 < nn; z++)
                b[z] = a[z - 1] & a[z] & a[z + 1];
            if (n > 1)
                b[nn - 1] = a[nn - 2] & a[nn - 1];
        }
        return;
    }
    /* Along x (axis 0) or y (axis 1): a row's neighbours are whole rows `stride` bytes away. */
    size_t stride = axis == 0 ? nn * nn : nn;
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++) {
            int c = axis == 0 ? x : y;
            size_t i = ((size_t)x * nn + (size_t)y) * nn;
            const unsigned char *a = src + i, *lo = c > 0 ? a - stride : a, *hi = c < n - 1 ? a + stride : a;
            unsigned char *b = dst + i;
            for (size_t z = 0; z < nn; z++)
                b[z] = lo[z] & a[z] & hi[z];
        }
}

int pixel_skip_build(pixel_skip *s, const voxel_grid *g)
{
    memset(s, 0, sizeof *s);
    if (!g || g->levels < 1)
        return 0;
    int k = skip_level(g);
    const grid_level *L = &g->level[k];
    int n = L->n;
    size_t count = (size_t)n * (size_t)n * (size_t)n;
    unsigned char *mask = malloc(count), *tmp = malloc(count);
    s->dist = malloc(count);
    if (!mask || !tmp || !s->dist) {
        free(mask);
        free(tmp);
        pixel_skip_free(s);
        return -1;
    }
    s->level = k;
    s->n = n;
    s->block = g->voxel_size_d * (double)(1 << k);
    for (int a = 0; a < 3; a++) {
        s->lo[a] = g->origin_d[a];
        s->hi[a] = g->origin_d[a] + (double)g->n * g->voxel_size_d;
    }
    /* Chessboard distance D to the nearest non-empty block: D >= d + 1 exactly where the cube of
     * half-width d blocks around the block is empty, i.e. the block survives d erosions of the empty
     * set by the 3x3x3 cube (separable: three 3-wide erosions, one per axis). */
    for (int x = 0; x < n; x++)
        for (int y = 0; y < n; y++)
            for (int z = 0; z < n; z++) {
                size_t i = ((size_t)x * (size_t)n + (size_t)y) * (size_t)n + (size_t)z;
                mask[i] = !grid_level_occupied(L, x, y, z);
                s->dist[i] = mask[i];
            }
    for (int d = 1; d < PIXEL_SKIP_CAP; d++) {
        erode(tmp, mask, n, 0);
        erode(mask, tmp, n, 1);
        erode(tmp, mask, n, 2);
        memcpy(mask, tmp, count);
        int any = 0;
        for (size_t i = 0; i < count; i++) {
            s->dist[i] = (unsigned char)(s->dist[i] + mask[i]);
            any |= mask[i];
        }
        if (!any)
            break;
    }
    free(mask);
    free(tmp);
    return 0;
}

void pixel_skip_free(pixel_skip *s)
{
    free(s->dist);
    s->dist = NULL;
}

/* Where a ray enters and leaves the box [lo, hi] (t >= 0); 0 when it misses it. */
static int ray_box(const double o[3], const double d[3], const double lo[3], const double hi[3], double *t_in,
                   double *t_out)
{
    double a = 0.0, b = INFINITY;
    for (int k = 0; k < 3; k++) {
        if (d[k] == 0.0) {
            if (o[k] < lo[k] || o[k] > hi[k])
                return 0;
            continue;
        }
        double t0 = (lo[k] - o[k]) / d[k], t1 = (hi[k] - o[k]) / d[k];
        if (t0 > t1) {
            double t = t0;
            t0 = t1;
            t1 = t;
        }
        a = t0 > a ? t0 : a;
        b = t1 < b ? t1 : b;
    }
    *t_in = a;
    *t_out = b;
    return a <= b;
}

float pixel_skip_t(const pixel_skip *s, vec3 org, const vec3 *dir, int count)
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
    for (int i = 0; i < count; i++) {
        const double di[3] = {dir[i].x, dir[i].y, dir[i].z};
        for (int a = 0; a < 3; a++) {
            double e = fabs(di[a] - d0[a]);
            if (!(e <= 1e30)) /* NaN or huge: no skip */
                return 0.0f;
            spread = e > spread ? e : spread;
        }
        double a, b;
        if (ray_box(o, di, s->lo, s->hi, &a, &b)) {
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
    /* A margin far above the rounding of these doubles and of the DDA's own (relative 1e-16 of the
     * coordinates; a thousandth of a block here). */
    const double margin = 1e-3 * s->block;
    const int n = s->n;
    /* The block of a point: by a multiplication (a point rounded into the next block is still within
     * a rounding error of its own, far inside the margin). */
    const double inv_block = 1.0 / s->block, min_step = 0.25 * s->block / (spread + speed);
    double t = t_lo, verified = t_lo; /* [0, verified]: no ray of the group meets a non-empty voxel */
    for (int iter = 0; iter < 4 * PIXEL_SKIP_MAX_N && t < t_hi; iter++) {
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
        int D = s->dist[((size_t)b[0] * (size_t)n + (size_t)b[1]) * (size_t)n + (size_t)b[2]];
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
