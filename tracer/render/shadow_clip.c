/* Shadow rays' ends toward a directional light (see shadow_clip.h). */
#include "shadow_clip.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "grid.h"
#include "vec_d.h"

/* Widening of every voxel's footprint and reach, in voxels: far above the rounding of these doubles
 * and of the DDA's (about 1e-13 of a voxel over a 1024^3 grid's diagonal) and of the float a reach is
 * kept in (1e-4 of a voxel at 2000 voxels), and far below anything that changes how soon a ray
 * stops. */
#define CLIP_MARGIN 1e-2

/* How fast the ray along to_light climbs toward the light, in lattice units per unit of its t; 0
 * when to_light is not the map's direction (the map's columns then say nothing about the ray). */
static double clip_speed(const shadow_clip *c, vec3 to_light)
{
    double s = c->g->voxel_size_d * (double)(1u << c->level); /* the level's cell, exact */
    double d[3] = {to_light.x / s, to_light.y / s, to_light.z / s}; /* the DDA's (gt_direction_prepare) */
    double speed = vx_dot3d(d, c->w);
    if (!(speed > 0.0) || !(fabs(vx_dot3d(d, c->u)) <= 1e-9 * speed) || !(fabs(vx_dot3d(d, c->v)) <= 1e-9 * speed))
        return 0.0;
    return speed;
}

/* A float at or above x (the reach is an upper bound, so it is rounded up). */
static float float_up(double x)
{
    float f = (float)x;
    return (double)f < x ? nextafterf(f, INFINITY) : f;
}

int shadow_clip_build(shadow_clip *c, const voxel_grid *g, vec3 to_light)
{
    return shadow_clip_build_cells(c, g, 0, 1.0, 0.0, to_light);
}

int shadow_clip_build_cells(shadow_clip *c, const voxel_grid *g, int level, double side, double slack, vec3 to_light)
{
    memset(c, 0, sizeof *c);
    double w[3] = {to_light.x, to_light.y, to_light.z};
    double len = sqrt(vx_dot3d(w, w));
    if (!g || level < 0 || level >= g->levels || !(len > 0.0) || !isfinite(len) || !(side >= 1.0) || !(slack >= 0.0))
        return 0; /* no map: the rays walk to the grid's edge */
    for (int a = 0; a < 3; a++)
        w[a] /= len;
    /* u: across w, from the axis w leans on least (never nearly parallel to w); v = w x u. */
    int least = fabs(w[0]) <= fabs(w[1]) ? (fabs(w[0]) <= fabs(w[2]) ? 0 : 2) : (fabs(w[1]) <= fabs(w[2]) ? 1 : 2);
    double e[3] = {0.0, 0.0, 0.0};
    e[least] = 1.0;
    double u[3] = {e[1] * w[2] - e[2] * w[1], e[2] * w[0] - e[0] * w[2], e[0] * w[1] - e[1] * w[0]};
    double ul = sqrt(vx_dot3d(u, u));
    for (int a = 0; a < 3; a++)
        u[a] /= ul;
    double v[3] = {w[1] * u[2] - w[2] * u[1], w[2] * u[0] - w[0] * u[2], w[0] * u[1] - w[1] * u[0]};
    /* The map spans the projection of the level's cube [0, n]^3 grown as much as a cell is (and the
     * widening below): it holds every grown cell's. */
    int n = g->level[level].n;
    double grow = 0.5 * (side - 1.0);
    double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY;
    for (int k = 0; k < 8; k++) {
        double p[3] = {(k & 1) ? n + grow : -grow, (k & 2) ? n + grow : -grow, (k & 4) ? n + grow : -grow};
        double pu = vx_dot3d(p, u), pv = vx_dot3d(p, v);
        umin = pu < umin ? pu : umin;
        umax = pu > umax ? pu : umax;
        vmin = pv < vmin ? pv : vmin;
        vmax = pv > vmax ? pv : vmax;
    }
    /* One voxel a column up to 512^3, then wider: at most about 890 columns a side (3 MB). A power of
     * two, so that a position's column is found by a multiplication as exact as the division. */
    double column = 1.0;
    while ((double)n / column > 512.0)
        column *= 2.0;
    /* A (grown) cell's half-extents along the map's axes, widened: a cube of edge `side` reaches
     * side * vx_cube_half_extent along an axis, and `slack` more per face at most sqrt(3) slack. */
    double widen = CLIP_MARGIN + 1.7320508075688772 * slack;
    double u0 = umin - 2.0 * widen, v0 = vmin - 2.0 * widen;
    int nu = (int)((umax - u0 + 2.0 * widen) / column) + 2;
    int nv = (int)((vmax - v0 + 2.0 * widen) / column) + 2;
    float *reach = malloc((size_t)nu * (size_t)nv * sizeof *reach);
    if (!reach)
        return -1;
    for (size_t i = 0; i < (size_t)nu * (size_t)nv; i++)
        reach[i] = -INFINITY;
    double hu = side * vx_cube_half_extent(u) + widen, hv = side * vx_cube_half_extent(v) + widen;
    double hw = side * vx_cube_half_extent(w) + widen;
    const grid_level *L = &g->level[level];
    for (size_t i = 0; i < L->count; i++) {
        int c[3];
        grid_coords(g, level, i, &c[0], &c[1], &c[2]);
        double centre[3] = {(double)c[0] + 0.5, (double)c[1] + 0.5, (double)c[2] + 0.5};
        double cu = vx_dot3d(centre, u) - u0, cv = vx_dot3d(centre, v) - v0;
        int iu0 = (int)((cu - hu) / column), iu1 = (int)((cu + hu) / column); /* >= 0: floor */
        int iv0 = (int)((cv - hv) / column), iv1 = (int)((cv + hv) / column);
        iu1 = iu1 < nu - 1 ? iu1 : nu - 1;
        iv1 = iv1 < nv - 1 ? iv1 : nv - 1;
        float r = float_up(vx_dot3d(centre, w) + hw);
        for (int iu = iu0; iu <= iu1; iu++)
            for (int iv = iv0; iv <= iv1; iv++) {
                float *cell = &reach[(size_t)iu * (size_t)nv + (size_t)iv];
                *cell = r > *cell ? r : *cell;
            }
    }
    memcpy(c->u, u, sizeof u);
    memcpy(c->v, v, sizeof v);
    memcpy(c->w, w, sizeof w);
    c->u0 = u0;
    c->v0 = v0;
    c->column = column;
    c->per_column = 1.0 / column;
    c->built_for = to_light;
    c->nu = nu;
    c->nv = nv;
    c->reach = reach;
    c->level = level;
    c->g = g;
    c->speed = clip_speed(c, to_light);
    return 0;
}

void shadow_clip_free(shadow_clip *c)
{
    free(c->reach);
    memset(c, 0, sizeof *c);
}

size_t shadow_clip_bytes(const shadow_clip *c)
{
    return c->g ? (size_t)c->nu * (size_t)c->nv * sizeof *c->reach : 0;
}

float shadow_clip_end(const shadow_clip *c, vec3 p, vec3 to_light, float t_max)
{
    if (!c->g)
        return t_max;
    double o[3];
    grid_to_lattice(c->g, p, o);
    return shadow_clip_end_lattice(c, o, to_light, t_max);
}

float shadow_clip_end_lattice(const shadow_clip *c, const double o[3], vec3 to_light, float t_max)
{
    if (!c->g)
        return t_max;
    /* The map's own direction (every shadow ray toward its light) has its speed at hand. */
    double speed = to_light.x == c->built_for.x && to_light.y == c->built_for.y && to_light.z == c->built_for.z
                       ? c->speed
                       : clip_speed(c, to_light);
    /* o in the map's level's units: a power of two apart, so exactly */
    double scale = 1.0 / (double)(1u << c->level), ol[3] = {o[0] * scale, o[1] * scale, o[2] * scale};
    double fu = floor((vx_dot3d(ol, c->u) - c->u0) * c->per_column);
    double fv = floor((vx_dot3d(ol, c->v) - c->v0) * c->per_column);
    /* Not the map's direction, or a point it cannot place: walk as usual. */
    if (!(speed > 0.0) || !isfinite(fu) || !isfinite(fv) || !isfinite(vx_dot3d(ol, c->w)))
        return t_max;
    if (fu < 0.0 || fv < 0.0 || fu >= c->nu || fv >= c->nv)
        return 0.0f; /* outside every voxel's footprint */
    float r = c->reach[(size_t)fu * (size_t)c->nv + (size_t)fv];
    if (r == -INFINITY)
        return 0.0f;
    double end = ((double)r - vx_dot3d(ol, c->w)) / speed;
    if (!(end < (double)t_max))
        return t_max;
    return end > 0.0 ? float_up(end) : 0.0f;
}
