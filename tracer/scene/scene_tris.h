/* Every triangle of a scene, instance copies included, without writing the copies out
 * (instancing.h). Numbering: the scene mesh's triangles first (0 .. mesh.triangle_count - 1), then
 * each instance's copy of its prototype's triangles, in instance order: copy i's triangle p is
 * mesh.triangle_count + inst[i].offset + p. A copy's corners come in the winding the written-out
 * copy would have (corners 1 and 2 swapped for a mirroring placement) and with its floats bit for
 * bit, so the voxeliser and the bake sampler see an instanced scene exactly as its expanded form. */
#ifndef VX_SCENE_TRIS_H
#define VX_SCENE_TRIS_H

#include <stddef.h>
#include <stdint.h>

#include "error.h"
#include "instancing.h"
#include "scene.h"

/* Triangles of the mesh plus every copy's. */
size_t scene_triangle_count(const scene *s);
/* World corners (x, y, z of corners 0, 1, 2) of triangles first .. first + count - 1. */
void scene_triangle_corners(const scene *s, size_t first, size_t count, float (*out)[9]);
/* World corners of instance I's copy of prototype triangle p (the same as scene_triangle_corners). */
void inst_corners(const scene_instancing *in, const inst_instance *I, uint32_t p, float out[9]);
/* The instance holding triangle number t >= mesh.triangle_count, and t's prototype triangle. */
const inst_instance *scene_triangle_instance(const scene *s, size_t t, uint32_t *proto_triangle);
/* Scene material of a hit: on the mesh's triangle prim (inst = UINT32_MAX, Embree's invalid
 * instance) or on instance inst's prototype triangle prim. */
uint32_t scene_hit_material(const scene *s, unsigned inst, unsigned prim);
/* Bounds over every triangle's corners (the copies' from inst_compute_bounds). */
void scene_triangle_bounds(const scene *s, double lo[3], double hi[3]);
/* The copies' bounds, computed once at load into s->inst->lo/hi; fails when a copy's corner is not
 * finite (a scale overflowing float). */
int inst_compute_bounds(scene *s, vx_err *e);

#endif
