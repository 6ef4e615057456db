/* `vmesh`: one voxel's record from its sample rays (Brito et al. 2023, §3.2-3.3, storage of §4).
 * Order matters: the eigenframe is quantised first and decoded back with the renderer's own decoder,
 * so the faces the normals are sorted into are exactly the faces the renderer will draw. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vmesh_bake.h"

#define STACK_RAYS 256 /* the default is 150 rays; more than this uses the heap */

typedef struct {
    vec3 normal; /* unit */
    vec3 albedo;
    int face;
} front_hit;

static signed char encode_snorm(float x)
{
    return (signed char)roundf(fminf(fmaxf(x, -1.0f), 1.0f) * 127.0f);
}

static unsigned char encode_unorm(float x)
{
    if (!(x > 0.0f)) /* also NaN */
        return 0;
    return (unsigned char)roundf(fminf(x, 1.0f) * 255.0f);
}

static void encode_vec(vec3 v, signed char out[3])
{
    out[0] = encode_snorm(v.x);
    out[1] = encode_snorm(v.y);
    out[2] = encode_snorm(v.z);
}

/* Octant face of a normal in the decoded frame (vmesh_record.h's indexing). */
static int face_of(const vmesh_octahedron *o, vec3 n)
{
    return (v3_dot(n, o->axis[0]) < 0.0f ? 1 : 0) | (v3_dot(n, o->axis[1]) < 0.0f ? 2 : 0) |
           (v3_dot(n, o->axis[2]) < 0.0f ? 4 : 0);
}

/* The virtual mesh from the front-facing hits (hits[i].face is filled here). */
static void build_mesh(vmesh_record *r, front_hit *hits, int front, vec3 *normals)
{
    for (int i = 0; i < front; i++)
        normals[i] = hits[i].normal;
    sggx_frame fit;
    sggx_fit(normals, front, VMESH_MIN_AREA, &fit);
    for (int k = 0; k < 3; k++) {
        encode_vec(fit.axis[k], r->axis[k]);
        r->area[k] = encode_unorm(fit.area[k]);
    }
    vmesh_octahedron o = vmesh_decode_octahedron(r);

    /* Counting sort of the normals by face, so each face's normals are contiguous. */
    int count[VMESH_FACES] = {0}, first[VMESH_FACES], fill[VMESH_FACES];
    vec3 color[VMESH_FACES];
    for (int i = 0; i < front; i++)
        count[hits[i].face = face_of(&o, hits[i].normal)]++;
    for (int f = 0, sum = 0; f < VMESH_FACES; sum += count[f], f++) {
        first[f] = fill[f] = sum;
        color[f] = v3(0, 0, 0);
    }
    for (int i = 0; i < front; i++) {
        normals[fill[hits[i].face]++] = hits[i].normal;
        color[hits[i].face] = v3_add(color[hits[i].face], hits[i].albedo);
    }
    for (int f = 0; f < VMESH_FACES; f++) {
        if (!count[f])
            continue; /* a face without normals holds nothing and is never drawn */
        vec3 dir[3];
        for (int k = 0; k < 3; k++)
            dir[k] = v3_normalize(vmesh_face_vertex(&o, f, k));
        vmesh_face_fit ff;
        vmesh_fit_face(normals + first[f], count[f], dir, &ff);
        for (int k = 0; k < 3; k++)
            encode_vec(ff.normal[k], r->normal[f][k]);
        vec3 c = v3_scale(color[f], 1.0f / (float)count[f]);
        r->color[f][0] = encode_unorm(c.x);
        r->color[f][1] = encode_unorm(c.y);
        r->color[f][2] = encode_unorm(c.z);
        r->faces |= (unsigned char)(1u << f);
        if (ff.distribution)
            r->distribution |= (unsigned char)(1u << f);
    }
}

void vmesh_bake_voxel(const vx_voxel *v, const vx_sample *samples, int n, void *out)
{
    vmesh_record *r = out;
    float sub[VMESH_SUBCELLS];
    vmesh_subgrid(v, samples, n, sub);
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        r->opacity[c] = encode_unorm(sub[c]);

    front_hit stack_hits[STACK_RAYS];
    vec3 stack_normals[STACK_RAYS];
    front_hit *hits = stack_hits;
    vec3 *normals = stack_normals;
    void *heap = NULL;
    if (n > STACK_RAYS) {
        heap = malloc((sizeof(front_hit) + sizeof(vec3)) * (size_t)n);
        if (!heap)
            return; /* out of memory: the opacities alone, an unshaded occluder */
        hits = heap;
        normals = (vec3 *)(hits + n);
    }
    int front = 0;
    float spec = 0.0f, rough = 0.0f;
    for (int i = 0; i < n; i++) {
        const vx_sample *s = &samples[i];
        float len = v3_length(s->normal);
        if (s->kind != VX_SAMPLE_INSIDE_FRONT || !(len > 1e-6f) || !isfinite(len))
            continue;
        hits[front].normal = v3_scale(s->normal, 1.0f / len);
        hits[front].albedo = s->albedo;
        front++;
        spec += s->specular;
        rough += s->roughness;
    }
    if (front > 0) {
        r->specular = encode_unorm(spec / (float)front);
        r->roughness = encode_unorm(sqrtf(0.5f * rough / (float)front));
        build_mesh(r, hits, front, normals);
    }
    free(heap);
}
