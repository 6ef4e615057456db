/* `vmesh`: one voxel's record from its sample rays (Brito et al. 2023, §3.2-3.3, storage of §4).
 * Order matters: the eigenframe is quantised first and decoded back with the renderer's own decoder,
 * so the faces the normals are sorted into are exactly the faces the renderer will draw. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "vmesh_bake.h"

#define STACK_RAYS 256 /* the default is 150 rays; more than this uses the heap */

signed char vmesh_encode_snorm(float x)
{
    return (signed char)roundf(vx_fminf(vx_fmaxf(x, -1.0f), 1.0f) * 127.0f);
}

unsigned char vmesh_encode_unorm(float x)
{
    if (!(x > 0.0f)) /* also NaN */
        return 0;
    return (unsigned char)roundf(vx_fminf(x, 1.0f) * 255.0f);
}

void vmesh_encode_vec(vec3 v, signed char out[3])
{
    out[0] = vmesh_encode_snorm(v.x);
    out[1] = vmesh_encode_snorm(v.y);
    out[2] = vmesh_encode_snorm(v.z);
}

int vmesh_face_of(const vmesh_octahedron *o, vec3 n)
{
    return (v3_dot(n, o->axis[0]) < 0.0f ? 1 : 0) | (v3_dot(n, o->axis[1]) < 0.0f ? 2 : 0) |
           (v3_dot(n, o->axis[2]) < 0.0f ? 4 : 0);
}

void vmesh_build_faces(vmesh_record *r, const vec3 *normals, const vec3 *albedo, const float *weight,
                       const vec3 *sort_dir, int n, int *face, vec3 *sorted)
{
    vmesh_octahedron o = vmesh_decode_octahedron(r);
    /* Counting sort of the normals by face, so each face's normals are contiguous. */
    int count[VMESH_FACES] = {0}, first[VMESH_FACES], fill[VMESH_FACES];
    vec3 color[VMESH_FACES];
    float mass[VMESH_FACES];
    for (int i = 0; i < n; i++)
        count[face[i] = vmesh_face_of(&o, sort_dir ? sort_dir[i] : normals[i])]++;
    for (int f = 0, sum = 0; f < VMESH_FACES; sum += count[f], f++) {
        first[f] = fill[f] = sum;
        color[f] = v3(0, 0, 0);
        mass[f] = 0.0f;
    }
    for (int i = 0; i < n; i++) {
        /* Weight 1 (the bake) adds exactly what an unweighted sum adds. */
        float w = weight ? weight[i] : 1.0f;
        sorted[fill[face[i]]++] = normals[i];
        color[face[i]] = v3_add(color[face[i]], v3_scale(albedo[i], w));
        mass[face[i]] += w;
    }
    for (int f = 0; f < VMESH_FACES; f++) {
        if (!count[f])
            continue; /* a face without normals holds nothing and is never drawn */
        vec3 dir[3];
        for (int k = 0; k < 3; k++)
            dir[k] = v3_normalize(vmesh_face_vertex(&o, f, k));
        vmesh_face_fit ff;
        vmesh_fit_face(sorted + first[f], count[f], dir, &ff);
        for (int k = 0; k < 3; k++)
            vmesh_encode_vec(ff.normal[k], r->normal[f][k]);
        vec3 c = mass[f] > 0.0f ? v3_scale(color[f], 1.0f / mass[f]) : v3(0, 0, 0);
        r->color[f][0] = vmesh_encode_unorm(c.x);
        r->color[f][1] = vmesh_encode_unorm(c.y);
        r->color[f][2] = vmesh_encode_unorm(c.z);
        r->faces |= (unsigned char)(1u << f);
        if (ff.distribution)
            r->distribution |= (unsigned char)(1u << f);
    }
}

void vmesh_encode_frame(vmesh_record *r, const sggx_frame *fit)
{
    for (int k = 0; k < 3; k++) {
        vmesh_encode_vec(fit->axis[k], r->axis[k]);
        r->area[k] = vmesh_encode_unorm(fit->area[k]);
    }
}

void vmesh_bake_voxel(const vx_voxel *v, const vx_sample *samples, int n, void *out)
{
    vmesh_record *r = out;
    float sub[VMESH_SUBCELLS];
    vmesh_subgrid(v, samples, n, sub);
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        r->opacity[c] = vmesh_encode_unorm(sub[c]);

    vec3 stack_vec[3 * STACK_RAYS];
    int stack_face[STACK_RAYS];
    vec3 *normals = stack_vec;
    int *face = stack_face;
    void *heap = NULL;
    if (n > STACK_RAYS) {
        heap = malloc((3 * sizeof(vec3) + sizeof(int)) * (size_t)n);
        if (!heap)
            return; /* out of memory: the opacities alone, an unshaded occluder */
        normals = heap;
        face = (int *)(normals + 3 * (size_t)n);
    }
    vec3 *albedo = normals + n, *sorted = normals + 2 * n;
    int front = 0;
    float spec = 0.0f, rough = 0.0f;
    for (int i = 0; i < n; i++) {
        const vx_sample *s = &samples[i];
        float len = v3_length(s->normal);
        if (s->kind != VX_SAMPLE_INSIDE_FRONT || !(len > 1e-6f) || !isfinite(len))
            continue;
        normals[front] = v3_scale(s->normal, 1.0f / len);
        albedo[front] = s->albedo;
        front++;
        spec += s->specular;
        rough += s->roughness;
    }
    if (front > 0) {
        r->specular = vmesh_encode_unorm(spec / (float)front);
        r->roughness = vmesh_encode_unorm(sqrtf(0.5f * rough / (float)front));
        /* The frame is encoded first and the faces sorted in its decoded form (see the top). */
        sggx_frame fit;
        sggx_fit(normals, front, VMESH_MIN_AREA, &fit);
        vmesh_encode_frame(r, &fit);
        vmesh_build_faces(r, normals, albedo, NULL, NULL, front, face, sorted);
    }
    free(heap);
}
