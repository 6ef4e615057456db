/* "spheres": a few smooth UV spheres of different radii resting on a square ground plane. The
 * smallest end-to-end scene: smooth normals exercise shading-normal handling, the ground's 0..1 uvs
 * carry a checker texture, and the contact points give sharp shadow detail. */
#include <math.h>

#include "generator.h"
#include "json_util.h"
#include "rng.h"

enum { SLOT_GROUND, SLOT_SPHERE, SLOT_SPHERE2 };
static const char *const sphere_slots[] = {"ground", "sphere", "sphere2", NULL};

typedef struct {
    int count, segments, rings;
    double ground_size;
} spheres_params;

typedef struct {
    vec3 centre;
    float radius;
} sphere_placement;

enum { MAX_SPHERES = 16 };

static int read_params(const cJSON *params, const char *where, spheres_params *p, vx_err *e)
{
    static const char *const known[] = {"count", "ground_size", "segments", "rings", NULL};
    p->count = 4;
    p->ground_size = 6.0;
    p->segments = 48;
    p->rings = 24;
    if (params && !cJSON_IsObject(params))
        return vx_fail(e, "%s: expected an object of parameters", where);
    if (json_only_fields(params, where, known, e) ||
        json_int_in(params, "count", where, 1, MAX_SPHERES, &p->count, e) ||
        json_number_in(params, "ground_size", where, 0.5, 1000.0, &p->ground_size, e) ||
        json_int_in(params, "segments", where, 3, 1024, &p->segments, e) ||
        json_int_in(params, "rings", where, 2, 512, &p->rings, e))
        return -1;
    return 0;
}

/* Rejection-samples non-overlapping spheres fully inside the ground square. Radii scale with the
 * ground so the layout looks the same at any ground_size. A sphere that finds no room after many
 * tries shrinks and tries again, so the loop always ends (a tiny sphere always fits somewhere). */
static void place_spheres(const spheres_params *p, uint64_t seed, sphere_placement *out)
{
    rng r = rng_seed(seed, 0);
    float half = (float)(0.5 * p->ground_size);
    float gap = 0.02f * (float)p->ground_size;
    for (int i = 0; i < p->count; i++) {
        float radius = (0.06f + 0.10f * rng_float(&r)) * (float)p->ground_size;
        for (;;) {
            int placed = 0;
            for (int attempt = 0; attempt < 200 && !placed; attempt++) {
                float x = (2.0f * rng_float(&r) - 1.0f) * (half - radius);
                float z = (2.0f * rng_float(&r) - 1.0f) * (half - radius);
                placed = 1;
                for (int j = 0; j < i; j++) {
                    float dx = x - out[j].centre.x, dz = z - out[j].centre.z;
                    float min_dist = radius + out[j].radius + gap;
                    if (dx * dx + dz * dz < min_dist * min_dist)
                        placed = 0;
                }
                if (placed) {
                    out[i].centre = v3(x, radius, z); /* resting on y = 0 */
                    out[i].radius = radius;
                }
            }
            if (placed)
                break;
            radius *= 0.8f;
        }
    }
}

/* A UV sphere: rings+1 latitude rows of segments+1 vertices (the seam column is duplicated so u
 * runs 0..1). The pole rows get one triangle per segment rather than a quad, because a quad there
 * would have two coincident corners and one zero-area triangle. */
static void add_uv_sphere(mesh *m, vec3 centre, float radius, int segments, int rings, uint32_t material)
{
    uint32_t first = (uint32_t)m->vertex_count;
    int row = segments + 1;
    for (int j = 0; j <= rings; j++) {
        double theta = M_PI * j / rings; /* from the north pole (+y) */
        for (int i = 0; i <= segments; i++) {
            double phi = 2.0 * M_PI * i / segments;
            vec3 n = v3((float)(sin(theta) * cos(phi)), (float)cos(theta), (float)(-sin(theta) * sin(phi)));
            if (j == 0 || j == rings)
                n = v3(0.0f, j == 0 ? 1.0f : -1.0f, 0.0f); /* exact poles, not sin(pi) ~ 1e-16 */
            mesh_add_vertex(m, v3_madd(centre, n, radius), n, (float)i / segments, (float)j / rings);
        }
    }
    for (int j = 0; j < rings; j++) {
        for (int i = 0; i < segments; i++) {
            uint32_t a = first + (uint32_t)(j * row + i), b = a + 1;
            uint32_t c = a + (uint32_t)row, d = c + 1;
            /* phi grows counter-clockwise seen from above (z = -sin), so a, c, d, b is
             * counter-clockwise seen from outside. */
            if (j != 0)
                mesh_add_triangle(m, a, c, b, material);
            if (j != rings - 1)
                mesh_add_triangle(m, b, c, d, material);
        }
    }
}

static int spheres_generate(const cJSON *params, const char *where, uint64_t seed, const uint32_t *slot_materials,
                            mesh *out, vx_err *e)
{
    spheres_params p;
    if (!where)
        where = "params";
    if (read_params(params, where, &p, e))
        return -1;

    float h = (float)(0.5 * p.ground_size);
    /* Counter-clockwise seen from above; mesh_add_quad gives a..d the uvs (0,0),(1,0),(1,1),(0,1). */
    mesh_add_quad(out, v3(-h, 0, h), v3(h, 0, h), v3(h, 0, -h), v3(-h, 0, -h), slot_materials[SLOT_GROUND]);

    sphere_placement placed[MAX_SPHERES];
    place_spheres(&p, seed, placed);
    for (int i = 0; i < p.count; i++) {
        uint32_t material = slot_materials[i % 2 ? SLOT_SPHERE2 : SLOT_SPHERE];
        add_uv_sphere(out, placed[i].centre, placed[i].radius, p.segments, p.rings, material);
    }
    return 0;
}

const scene_generator generator_spheres = {
    .name = "spheres",
    .description = "UV spheres of different radii on a square ground plane (params: count, ground_size, "
                   "segments, rings); odd-numbered spheres use slot sphere2",
    .slots = sphere_slots,
    .generate = spheres_generate,
};
