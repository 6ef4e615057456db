/* View tiles: the direction along which the voxel tracer asks the opacity of a voxel's cached
 * answer toward the camera, for a model that asks for them (vx_voxel_eval.view_tile_pixels,
 * models/model.h). Without them it is the exact direction between the voxel's centre and the camera,
 * a different one for every voxel; with them, the direction from the camera through the centre of
 * the cell, k pixels wide, of a square lattice on the image plane that the voxel's centre projects
 * into. Every voxel projected into one cell gets the same bits, so a model can do the part of its
 * opacity that depends on the direction alone once per cell (vmesh's views: most of its primary
 * evaluation). The shading's direction toward the viewer stays exact: vmesh's specular shading
 * moves ~60 times more than its opacity under the same tile (bunny 256^3: image MSE 7.1e-7 against
 * 1.2e-8 from the opacity alone).
 *
 * The error: the lattice lies on the image plane at distance 1, with a corner on the camera's axis
 * and cells `tile` = k pixels wide (2 k spread, camera_pixel_spread being half a pixel); the
 * direction's point on that plane moves by at most tile / sqrt(2), and the angle between two
 * directions through the plane is at most the distance between their points there (the plane keeps
 * its points at least 1 from the eye), so the direction turns by at most tile / sqrt(2) radians:
 * k / sqrt(2) pixels' angle on the axis, less off it (tests/unit_view_tile.c).
 *
 * Portable C (the OpenCL tracer includes it through render_voxel_core.h): both backends compute the
 * same directions. */
#ifndef VX_VIEW_TILE_H
#define VX_VIEW_TILE_H

#include "camera.h"

/* The lattice's cell width on the image plane at distance 1 for tiles of `pixels` (the render's,
 * render_view_tile_pixels) on an image whose pixel spread is `spread`; 0 (the exact direction) when
 * `pixels` is 0. */
VX_INLINE float view_tile_width(int pixels, float spread) { return pixels > 0 ? 2.0f * spread * (float)pixels : 0.0f; }

/* Below this cosine between the camera's axis and the direction to a voxel's centre the exact
 * direction is kept: the image plane's coordinates grow without bound toward 90 degrees (and a
 * voxel beside or behind the eye has none). Any voxel inside a frustum of up to 160 degrees lies
 * above it. */
#define VIEW_TILE_MIN_COS 0.1f

/* The direction to ask a voxel's opacity along, given d, the unit vector from the camera c toward
 * the voxel's centre: d itself when tile is 0, else the unit vector from the camera through the
 * centre of the lattice cell the voxel's centre projects into. */
VX_INLINE vec3 view_tile_direction(const camera *c, float tile, vec3 d)
{
    float along = v3_dot(d, c->forward);
    if (!(tile > 0.0f) || !(along >= VIEW_TILE_MIN_COS))
        return d;
    float u = v3_dot(d, c->right) / along, v = v3_dot(d, c->up) / along;
    u = (floorf(u / tile) + 0.5f) * tile;
    v = (floorf(v / tile) + 0.5f) * tile;
    vec3 p = v3_add(c->forward, v3_add(v3_scale(c->right, u), v3_scale(c->up, v)));
    return v3_normalize_or(p, d);
}

#endif
