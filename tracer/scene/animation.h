/* Rigid animation of a scene's objects (the dynamic-SVO paper's moving objects, issue 17): an
 * object may carry "animation": {"keys": [{"frame": F, "translate": [x,y,z], "rotate_deg": [x,y,z],
 * "scale": s}, ...]} and the scene "frames": [A, B]. A key's pose maps the object as loaded (after
 * its own "transform") to p' = R (s p) + t; between keys translation and scale are linear and the
 * rotation is the quaternion slerp, outside them the nearest key holds. The scene's mesh always
 * holds one frame's pose (frame A after loading); scene_set_frame moves it. */
#ifndef VX_ANIMATION_H
#define VX_ANIMATION_H

#include <stddef.h>

#include <cjson/cJSON.h>
#include "error.h"
#include "scene.h"

typedef struct {
    double frame;
    double t[3];
    double q[4]; /* unit quaternion w, x, y, z */
    double scale;
} anim_key;

typedef struct {
    int object;           /* index in the scene's "objects" */
    size_t v0, v1;        /* its vertices [v0, v1) (triangles are the object's when their first vertex is) */
    float *rest_pos, *rest_nrm; /* its vertices as loaded: what the keys' poses apply to */
    anim_key *keys;       /* by increasing frame */
    int key_count;
} anim_object;

typedef struct scene_animation {
    anim_object *objects;
    int count;
    int first, last; /* "frames": [A, B] */
    double frame;    /* the pose the scene's mesh holds */
    double lo[3], hi[3]; /* bounds of every triangle over every frame of [A, B] and every key */
} scene_animation;

/* scene.c's hooks: an object's "animation" (absent: nothing), then the scene's "frames" once every
 * object is loaded (poses frame A and computes the bounds). */
int anim_parse_object(scene *s, const cJSON *object, const char *where, int index, size_t v0, vx_err *e);
int anim_parse_frames(scene *s, const cJSON *root, vx_err *e);
void anim_free(scene_animation *a);

/* The pose of object o at `frame`: p' = A p + t, A row-major 3x3 (rotation times scale). */
void anim_pose(const anim_object *o, double frame, double A[9], double t[3]);
/* Poses every animated object at `frame` (scene_set_frame in scene.h is the caller's entry). */
void anim_pose_all(scene_animation *a, mesh *m, int frame);
/* The object owning triangle t (index into s->anim->objects), or -1 for a static triangle. */
int anim_triangle_owner(const scene *s, size_t t);
/* 1 and the bounds of the whole animation when s has moving objects (the grid is then one lattice
 * for every frame), else 0. */
int anim_grid_bounds(const scene *s, double lo[3], double hi[3]);

#endif
