/* Keyframed rigid animation (format in animation.h and README.md): parsing with errors that name
 * the field, interpolation (linear translation and scale, quaternion slerp), posing the scene's mesh
 * at a frame, and the bounds of the whole animation (one grid lattice for every frame, so that
 * static voxels are baked once and moving ones land on the same cells as a re-bake's). */
#include "animation.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_util.h"

/* Rotation about x, then y, then z (degrees): the same order as an object's "transform". */
static void euler_to_quat(const double deg[3], double q[4])
{
    q[0] = 1, q[1] = q[2] = q[3] = 0;
    for (int axis = 0; axis < 3; axis++) {
        double h = deg[axis] * M_PI / 360.0, c = cos(h), s = sin(h);
        double r[4] = {c, 0, 0, 0};
        r[1 + axis] = s;
        /* q = r * q: the later rotation applies after the earlier ones. */
        double w = r[0] * q[0] - r[1] * q[1] - r[2] * q[2] - r[3] * q[3];
        double x = r[0] * q[1] + r[1] * q[0] + r[2] * q[3] - r[3] * q[2];
        double y = r[0] * q[2] - r[1] * q[3] + r[2] * q[0] + r[3] * q[1];
        double z = r[0] * q[3] + r[1] * q[2] - r[2] * q[1] + r[3] * q[0];
        q[0] = w, q[1] = x, q[2] = y, q[3] = z;
    }
}

static void quat_to_matrix(const double q[4], double R[9])
{
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

static void slerp(const double a[4], const double b0[4], double u, double out[4])
{
    double b[4], d = a[0] * b0[0] + a[1] * b0[1] + a[2] * b0[2] + a[3] * b0[3];
    double sign = d < 0 ? -1.0 : 1.0; /* the short way round */
    for (int k = 0; k < 4; k++)
        b[k] = sign * b0[k];
    d *= sign;
    double wa, wb;
    if (d > 0.9995) { /* nearly equal: linear, normalised below */
        wa = 1 - u, wb = u;
    } else {
        double th = acos(d), s = sin(th);
        wa = sin((1 - u) * th) / s, wb = sin(u * th) / s;
    }
    double n = 0;
    for (int k = 0; k < 4; k++) {
        out[k] = wa * a[k] + wb * b[k];
        n += out[k] * out[k];
    }
    n = sqrt(n);
    for (int k = 0; k < 4; k++)
        out[k] /= n;
}

void anim_pose(const anim_object *o, double frame, double A[9], double t[3])
{
    const anim_key *k = o->keys;
    int n = o->key_count, i = 0;
    anim_key p;
    if (frame <= k[0].frame) {
        p = k[0];
    } else if (frame >= k[n - 1].frame) {
        p = k[n - 1];
    } else {
        while (k[i + 1].frame <= frame)
            i++;
        double u = (frame - k[i].frame) / (k[i + 1].frame - k[i].frame);
        p.frame = frame;
        for (int a = 0; a < 3; a++)
            p.t[a] = k[i].t[a] + u * (k[i + 1].t[a] - k[i].t[a]);
        p.scale = k[i].scale + u * (k[i + 1].scale - k[i].scale);
        slerp(k[i].q, k[i + 1].q, u, p.q);
    }
    quat_to_matrix(p.q, A);
    for (int a = 0; a < 9; a++)
        A[a] *= p.scale;
    memcpy(t, p.t, sizeof p.t);
}

int anim_parse_object(scene *s, const cJSON *object, const char *where, int index, size_t v0, vx_err *e)
{
    const cJSON *an = cJSON_GetObjectItemCaseSensitive(object, "animation");
    if (!an)
        return 0;
    char w[700], wk[760];
    snprintf(w, sizeof w, "%s.animation", where);
    static const char *const known[] = {"keys", NULL};
    static const char *const key_fields[] = {"frame", "translate", "rotate_deg", "scale", NULL};
    if (!cJSON_IsObject(an))
        return vx_fail(e, "%s: expected an object with \"keys\"", w);
    if (json_only_fields(an, w, known, e))
        return -1;
    const cJSON *keys = cJSON_GetObjectItemCaseSensitive(an, "keys");
    int n = cJSON_IsArray(keys) ? cJSON_GetArraySize(keys) : 0;
    if (n < 1)
        return vx_fail(e, "%s.keys: expected a non-empty array of keys {\"frame\", \"translate\", \"rotate_deg\", \"scale\"}", w);
    if (!s->anim && !(s->anim = calloc(1, sizeof *s->anim)))
        return vx_fail(e, "%s: out of memory", w);
    scene_animation *a = s->anim;
    anim_object *grown = realloc(a->objects, (size_t)(a->count + 1) * sizeof *grown);
    if (!grown)
        return vx_fail(e, "%s: out of memory", w);
    a->objects = grown;
    anim_object *o = &a->objects[a->count++];
    memset(o, 0, sizeof *o);
    o->object = index;
    o->v0 = v0;
    o->v1 = s->mesh.vertex_count;
    o->keys = calloc((size_t)n, sizeof *o->keys);
    size_t nv = o->v1 - o->v0;
    o->rest_pos = malloc((nv ? nv : 1) * 3 * sizeof(float));
    o->rest_nrm = malloc((nv ? nv : 1) * 3 * sizeof(float));
    if (!o->keys || !o->rest_pos || !o->rest_nrm)
        return vx_fail(e, "%s: out of memory", w);
    memcpy(o->rest_pos, s->mesh.positions + 3 * v0, nv * 3 * sizeof(float));
    memcpy(o->rest_nrm, s->mesh.normals + 3 * v0, nv * 3 * sizeof(float));
    const cJSON *k;
    int i = 0;
    cJSON_ArrayForEach(k, keys)
    {
        snprintf(wk, sizeof wk, "%s.keys[%d]", w, i);
        anim_key *key = &o->keys[i];
        if (!cJSON_IsObject(k))
            return vx_fail(e, "%s: expected an object {\"frame\", \"translate\", \"rotate_deg\", \"scale\"}", wk);
        if (json_only_fields(k, wk, key_fields, e))
            return -1;
        if (!cJSON_GetObjectItemCaseSensitive(k, "frame"))
            return vx_fail(e, "%s: missing field \"frame\" (an integer frame number)", wk);
        int frame = 0;
        double scale = 1;
        vec3 tr = v3(0, 0, 0), rot = v3(0, 0, 0);
        if (json_int_in(k, "frame", wk, 0, 1000000, &frame, e) || json_vec3(k, "translate", wk, &tr, e) ||
            json_vec3(k, "rotate_deg", wk, &rot, e) || json_number_in(k, "scale", wk, 1e-3, 1e3, &scale, e))
            return -1;
        if (i > 0 && frame <= o->keys[i - 1].frame)
            return vx_fail(e, "%s.frame: %d, but keys must have increasing frames (the previous key is at %g)", wk,
                           frame, o->keys[i - 1].frame);
        key->frame = frame;
        key->t[0] = tr.x, key->t[1] = tr.y, key->t[2] = tr.z;
        key->scale = scale;
        double deg[3] = {rot.x, rot.y, rot.z};
        euler_to_quat(deg, key->q);
        i++;
    }
    o->key_count = n;
    return 0;
}

/* Poses object o's vertices at `frame` from its rest copy. */
static void pose_object(mesh *m, const anim_object *o, double frame)
{
    double A[9], t[3];
    anim_pose(o, frame, A, t);
    /* Normals: the rotation alone (the scale is uniform and positive). */
    double sc = cbrt(A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
                     A[2] * (A[3] * A[7] - A[4] * A[6]));
    for (size_t v = o->v0; v < o->v1; v++) {
        const float *p = o->rest_pos + 3 * (v - o->v0), *n = o->rest_nrm + 3 * (v - o->v0);
        for (int r = 0; r < 3; r++) {
            m->positions[3 * v + r] =
                (float)(A[3 * r] * p[0] + A[3 * r + 1] * p[1] + A[3 * r + 2] * p[2] + t[r]);
            m->normals[3 * v + r] = (float)((A[3 * r] * n[0] + A[3 * r + 1] * n[1] + A[3 * r + 2] * n[2]) / sc);
        }
    }
}

static void grow_bounds(const mesh *m, double lo[3], double hi[3])
{
    for (size_t t = 0; t < m->triangle_count; t++)
        for (int k = 0; k < 3; k++) {
            const float *p = m->positions + 3 * (size_t)m->indices[3 * t + (size_t)k];
            for (int a = 0; a < 3; a++) {
                lo[a] = vx_fmin(lo[a], p[a]);
                hi[a] = vx_fmax(hi[a], p[a]);
            }
        }
}

int anim_parse_frames(scene *s, const cJSON *root, vx_err *e)
{
    const cJSON *fr = cJSON_GetObjectItemCaseSensitive(root, "frames");
    if (!fr) {
        if (s->anim)
            return vx_fail(e, "%s: frames: required when an object has an \"animation\" (e.g. \"frames\": [0, 47])", s->path);
        return 0;
    }
    char w[600];
    snprintf(w, sizeof w, "%s: frames", s->path);
    const cJSON *a0 = cJSON_GetArrayItem(fr, 0), *a1 = cJSON_GetArrayItem(fr, 1);
    if (!cJSON_IsArray(fr) || cJSON_GetArraySize(fr) != 2 || !cJSON_IsNumber(a0) || !cJSON_IsNumber(a1) ||
        a0->valuedouble != floor(a0->valuedouble) || a1->valuedouble != floor(a1->valuedouble) ||
        a0->valuedouble < 0 || a1->valuedouble < a0->valuedouble || a1->valuedouble > 1000000)
        return vx_fail(e, "%s: expected [A, B], integers with 0 <= A <= B <= 1000000", w);
    if (!s->anim && !(s->anim = calloc(1, sizeof *s->anim)))
        return vx_fail(e, "%s: out of memory", w);
    scene_animation *an = s->anim;
    an->first = (int)a0->valuedouble;
    an->last = (int)a1->valuedouble;
    /* The whole animation's bounds: every integer frame, and every key (the keys are the extremes
     * of translation and scale; rotations between integer frames move a vertex less than between
     * the frames themselves, covered by the grid's 1.5-cell padding). */
    for (int k = 0; k < 3; k++)
        an->lo[k] = INFINITY, an->hi[k] = -INFINITY;
    for (int f = an->first; f <= an->last; f++) {
        for (int i = 0; i < an->count; i++)
            pose_object(&s->mesh, &an->objects[i], f);
        grow_bounds(&s->mesh, an->lo, an->hi);
        if (an->count == 0)
            break;
    }
    for (int i = 0; i < an->count; i++)
        pose_object(&s->mesh, &an->objects[i], an->first);
    an->frame = an->first;
    return 0;
}

void anim_pose_all(scene_animation *a, mesh *m, int frame)
{
    for (int i = 0; i < a->count; i++)
        pose_object(m, &a->objects[i], frame);
    a->frame = frame;
}

int anim_triangle_owner(const scene *s, size_t t)
{
    if (!s->anim)
        return -1;
    size_t v = s->mesh.indices[3 * t];
    for (int i = 0; i < s->anim->count; i++)
        if (v >= s->anim->objects[i].v0 && v < s->anim->objects[i].v1)
            return i;
    return -1;
}

int anim_grid_bounds(const scene *s, double lo[3], double hi[3])
{
    if (!s->anim || s->anim->count == 0)
        return 0;
    memcpy(lo, s->anim->lo, 3 * sizeof *lo);
    memcpy(hi, s->anim->hi, 3 * sizeof *hi);
    return 1;
}

void anim_free(scene_animation *a)
{
    if (!a)
        return;
    for (int i = 0; i < a->count; i++) {
        free(a->objects[i].keys);
        free(a->objects[i].rest_pos);
        free(a->objects[i].rest_nrm);
    }
    free(a->objects);
    free(a);
}
