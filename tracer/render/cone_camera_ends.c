/* The camera cones' ends (see cone_camera_ends.h). */
#include "cone_camera_ends.h"

#include "cone_levels.h"

/* What bounds the cones' elements' radii over the image. A pixel's cone whose centre ray makes cos
 * with the camera's axis has the spread s = camera_cone_spread(spread, cos), proportional to
 * cos^(3/2), and reaches depth z at t = z / cos: its radius without the floor, s t, is q z with
 * q = s / cos, proportional to sqrt(cos), greatest on the axis and least at the image's corners. */
typedef struct {
    double q_min, q_max; /* the pixels' radii per unit depth: at the image's corners, on its axis */
    double s_max;        /* the pixels' greatest spread (on the axis) */
    double r_min;        /* the cones' floor radius (cone_trace's) */
    float level_scale;   /* cone_walk_start's */
    int top;
} cone_reach;

/* The proof level of an element of radius r (the marcher's own functions). */
static int reach_level(const cone_reach *R, double r)
{
    return cone_proof_level(cone_element_level((float)r, R->level_scale, R->top), R->top);
}

/* pixel_bounds_keep: whether an element centred at a depth in [z_near, z_far] may have proof level
 * `level`. An element that starts at t has the radius r = R(t + R(t)), R(u) = max(s u, r_min)
 * (cone_radius), and its centre at tc = t + r, where s tc = q z. So r <= R(tc + R(tc)) (t <= tc),
 * at most q_max z_far + s_max max(q_max z_far, r_min); and r >= s t = s tc - s r, so
 * r >= q z / (1 + s) >= q_min z_near / (1 + s_max), and r >= r_min. A relative 1e-4 covers the
 * float arithmetic. */
static int reach_keep(const void *ctx, int level, double z_near, double z_far)
{
    const cone_reach *R = ctx;
    if (!(z_far >= 0.0))
        return 0;
    double z_lo = z_near > 0.0 ? z_near : 0.0, a = fmax(R->q_max * z_far, R->r_min);
    double r_lo = fmax(R->q_min * z_lo / (1.0 + R->s_max), R->r_min) * (1.0 - 1e-4);
    double r_hi = fmax(R->q_max * z_far + R->s_max * a, R->r_min) * (1.0 + 1e-4);
    return reach_level(R, r_lo) <= level && level <= reach_level(R, r_hi);
}

/* Whether reach_keep may keep a block of `level` of grid g, whose box spans the depths [zg0, zg1]:
 * a block's centre lies up to half a block past the box on an axis (a last, partial block), so up
 * to sqrt(3) / 2 of a block in depth, and its grown cube's depths up to sqrt(3) / 2 of 3 blocks from
 * its centre: 2 sqrt(3) < 3.5 blocks past the box's depths (with the build's margins). */
static int level_reaches(const cone_reach *R, const voxel_grid *g, int level, double zg0, double zg1, double margin)
{
    double reach = (3.5 * (double)(1 << level) + 0.01) * g->voxel_size_d + margin;
    return reach_keep(R, level, zg0 - reach, zg1 + reach);
}

static void build(pixel_bounds *b, const voxel_grid *g, const camera *cam, float spread, int threads, int every_level)
{
    if (!b->near_t)
        return;
    cone_reach R;
    /* The pixels' centre rays make their widest angles with the axis at the image's corners. */
    double cos_min = 1.0;
    for (int k = 0; k < 4; k++) {
        vec3 org, dir;
        camera_ray(cam, b->width, b->height, k & 1 ? (float)b->width - 0.5f : 0.5f,
                   k & 2 ? (float)b->height - 0.5f : 0.5f, 0.5f, 0.5f, 0, &org, &dir);
        double c = v3_dot(dir, cam->forward);
        cos_min = c < cos_min ? c : cos_min;
    }
    cos_min -= 1e-6;
    R.s_max = camera_cone_spread(spread, 1.0f);
    R.q_max = R.s_max;
    R.q_min = cos_min > 0.0 ? R.s_max * sqrt(cos_min) : 0.0;
    R.r_min = 0.125f * g->voxel_size;
    R.level_scale = 2.0f / g->voxel_size;
    R.top = g->levels - 1;
    /* The grid's depths, and how far a float centre org + t dir may lie off the exact ray: two
     * roundings of (|org| + t) a coordinate, t up to past the grid's far corner (the cones' reach
     * grows the box by a few radii); far more than that, in world units. */
    double zg0 = INFINITY, zg1 = -INFINITY, far = 0.0;
    for (int k = 0; k < 8; k++) {
        double c[3], z = 0.0, d2 = 0.0;
        for (int a = 0; a < 3; a++) {
            c[a] = g->origin_d[a] + ((k >> a) & 1 ? g->n * g->voxel_size_d : 0.0) - (double)v3_get(cam->position, a);
            z += c[a] * (double)v3_get(cam->forward, a);
            d2 += c[a] * c[a];
        }
        zg0 = z < zg0 ? z : zg0;
        zg1 = z > zg1 ? z : zg1;
        far = sqrt(d2) > far ? sqrt(d2) : far;
    }
    double pos = fmax(fmax(fabs(cam->position.x), fabs(cam->position.y)), fabs(cam->position.z));
    double margin = (pos + 4.0 * far) * 0x1p-21;
    if (!(cos_min > 0.0) || !(margin < INFINITY)) {
        /* A field of view of 180 degrees or more, or a camera at infinity: no map this frame (the
         * parts stay empty, as every build leaves them). */
        b->failed = 1;
        return;
    }
    /* The levels whose blocks may be kept; the others' blocks are not looked at. */
    int lo = 1, hi = R.top;
    if (!every_level) {
        while (lo <= hi && !level_reaches(&R, g, lo, zg0, zg1, margin))
            lo++;
        while (hi >= lo && !level_reaches(&R, g, hi, zg0, zg1, margin))
            hi--;
    }
    pixel_bounds_build_cells(b, g, cam, threads, lo, hi, 3.0, margin, reach_keep, &R);
}

void cone_camera_ends_build(pixel_bounds *b, const voxel_grid *g, const camera *cam, float spread, int threads)
{
    build(b, g, cam, spread, threads, 0);
}

void cone_camera_ends_build_every_level(pixel_bounds *b, const voxel_grid *g, const camera *cam, float spread,
                                        int threads)
{
    build(b, g, cam, spread, threads, 1);
}
