/* "island": a height-field island (smooth radial falloff plus a few octaves of value noise) rising
 * out of a flat sea, with palm trees: curved, segmented low-poly trunks and crowns of drooping
 * fronds. Mixes a large smooth surface (terrain, sea) with thin detailed geometry (fronds). */
#include <math.h>
#include <stdlib.h>

#include "generator.h"
#include "json_util.h"
#include "rng.h"

enum { SLOT_SAND, SLOT_SEA, SLOT_TRUNK, SLOT_FROND };
static const char *const island_slots[] = {"sand", "sea", "trunk", "frond", NULL};

typedef struct {
    int resolution, palms;
    double size, height, sea_size;
} island_params;

enum { NOISE_OCTAVES = 4, NOISE_BASE_CELLS = 4, TRUNK_SEGMENTS = 8, TRUNK_SIDES = 6, FROND_SEGMENTS = 8 };

static int read_params(const cJSON *params, const char *where, island_params *p, vx_err *e)
{
    static const char *const known[] = {"resolution", "palms", "size", "height", "sea_size", NULL};
    p->resolution = 128;
    p->palms = 6;
    p->size = 12.0;
    p->height = 1.5;
    p->sea_size = -1.0; /* default depends on size */
    if (params && !cJSON_IsObject(params))
        return vx_fail(e, "%s: expected an object of parameters", where);
    if (json_only_fields(params, where, known, e) ||
        json_int_in(params, "resolution", where, 8, 2048, &p->resolution, e) ||
        json_int_in(params, "palms", where, 0, 64, &p->palms, e) ||
        json_number_in(params, "size", where, 1.0, 1000.0, &p->size, e) ||
        json_number_in(params, "height", where, 0.01 * p->size, 0.5 * p->size, &p->height, e))
        return -1;
    double sea_default = 1.25 * p->size;
    if (p->sea_size < 0)
        p->sea_size = sea_default;
    /* The sea must cover the terrain's submerged skirt, or its edges would show. */
    if (json_number_in(params, "sea_size", where, p->size, 10.0 * p->size, &p->sea_size, e))
        return -1;
    return 0;
}

/* Value noise: per octave a lattice of random values in [-1, 1] over the terrain square,
 * interpolated with the quintic fade so the terrain (and its normals) have no lattice creases. */
typedef struct {
    float *values[NOISE_OCTAVES];
    int cells[NOISE_OCTAVES];
    float half_size;
} value_noise;

static void noise_init(value_noise *n, uint64_t seed, float size)
{
    rng r = rng_seed(seed, 1);
    n->half_size = 0.5f * size;
    for (int o = 0; o < NOISE_OCTAVES; o++) {
        int cells = NOISE_BASE_CELLS << o;
        n->cells[o] = cells;
        n->values[o] = malloc(sizeof(float) * (size_t)((cells + 1) * (cells + 1)));
        if (!n->values[o])
            abort(); /* as mesh.c: a few KiB failing is not an input error */
        for (int i = 0; i < (cells + 1) * (cells + 1); i++)
            n->values[o][i] = 2.0f * rng_float(&r) - 1.0f;
    }
}

static void noise_free(value_noise *n)
{
    for (int o = 0; o < NOISE_OCTAVES; o++)
        free(n->values[o]);
}

static float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }

/* Roughly in [-1, 1]: octaves with amplitudes 1, 1/2, 1/4, ... normalised by their sum. */
static float noise_at(const value_noise *n, float x, float z)
{
    float sum = 0.0f, total = 0.0f, amplitude = 1.0f;
    for (int o = 0; o < NOISE_OCTAVES; o++) {
        int cells = n->cells[o];
        float fx = (x / n->half_size * 0.5f + 0.5f) * (float)cells;
        float fz = (z / n->half_size * 0.5f + 0.5f) * (float)cells;
        fx = fminf(fmaxf(fx, 0.0f), (float)cells - 1e-4f);
        fz = fminf(fmaxf(fz, 0.0f), (float)cells - 1e-4f);
        int ix = (int)fx, iz = (int)fz;
        float tx = fade(fx - (float)ix), tz = fade(fz - (float)iz);
        const float *v = n->values[o];
        int row = cells + 1;
        float a = v[iz * row + ix], b = v[iz * row + ix + 1];
        float c = v[(iz + 1) * row + ix], d = v[(iz + 1) * row + ix + 1];
        float value = (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * tz;
        sum += amplitude * value;
        total += amplitude;
        amplitude *= 0.5f;
    }
    return sum / total;
}

/* Terrain height: a bump (1 - r^2)^2 that is zero at the square's inscribed circle, modulated by
 * noise, lowered so the coast (height 0) lies at roughly two thirds of the half-size and the
 * square's edges are well under water. */
static float terrain_height(const value_noise *n, const island_params *p, float x, float z)
{
    float qx = x / n->half_size, qz = z / n->half_size;
    float r2 = fminf(qx * qx + qz * qz, 1.0f);
    float bump = (1.0f - r2) * (1.0f - r2);
    float noise = noise_at(n, x, z);
    return (float)p->height * (bump * (1.0f + 0.35f * noise) - 0.3f + 0.1f * noise);
}

static float smoothstep(float lo, float hi, float x)
{
    float t = fminf(fmaxf((x - lo) / (hi - lo), 0.0f), 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

static void add_terrain(mesh *m, const value_noise *n, const island_params *p, uint32_t material)
{
    int res = p->resolution;
    float half = 0.5f * (float)p->size, height = (float)p->height;
    size_t first_vertex = m->vertex_count, first_triangle = m->triangle_count;
    /* Vertex colours multiply the sand material: white on the beach, a green tint inland. */
    vec3 grass_tint = v3(0.45f, 0.8f, 0.35f);
    for (int j = 0; j <= res; j++) {
        for (int i = 0; i <= res; i++) {
            float x = -half + (float)p->size * (float)i / (float)res;
            float z = -half + (float)p->size * (float)j / (float)res;
            float y = terrain_height(n, p, x, z);
            uint32_t v = mesh_add_vertex(m, v3(x, y, z), v3(0, 1, 0), (float)i / (float)res, (float)j / (float)res);
            float grass = smoothstep(0.2f * height, 0.45f * height, y);
            mesh_set_vertex_color(m, v, v3_add(v3_scale(v3(1, 1, 1), 1.0f - grass), v3_scale(grass_tint, grass)));
        }
    }
    uint32_t row = (uint32_t)res + 1;
    for (uint32_t j = 0; j < (uint32_t)res; j++) {
        for (uint32_t i = 0; i < (uint32_t)res; i++) {
            uint32_t a = (uint32_t)first_vertex + j * row + i; /* (x0, z0) */
            uint32_t b = a + row;                              /* (x0, z1) */
            uint32_t c = b + 1, d = a + 1;                     /* (x1, z1), (x1, z0) */
            /* (x0,z0), (x0,z1), (x1,z1) is counter-clockwise seen from +y. */
            mesh_add_triangle(m, a, b, c, material);
            mesh_add_triangle(m, a, c, d, material);
        }
    }
    mesh_smooth_normals(m, first_vertex, first_triangle);
}

/* A curved palm trunk: rings of TRUNK_SIDES vertices along p(t) = base + up*L*t + lean*L*k*t^2,
 * a parabola in the plane of up and the lean direction. The ring frame (u, v) keeps u normal to
 * that plane, so it never twists. Returns the top centre. */
static vec3 add_palm_trunk(mesh *m, vec3 base, vec3 lean_dir, float length, float lean, float radius,
                           uint32_t material)
{
    vec3 up = v3(0, 1, 0);
    vec3 u = v3_normalize(v3_cross(up, lean_dir));
    uint32_t first = (uint32_t)m->vertex_count;
    vec3 centre = base, tangent = up;
    for (int k = 0; k <= TRUNK_SEGMENTS; k++) {
        float t = (float)k / TRUNK_SEGMENTS;
        centre = v3_madd(v3_madd(base, up, length * t), lean_dir, length * lean * t * t);
        tangent = v3_normalize(v3_madd(up, lean_dir, 2.0f * lean * t));
        vec3 v = v3_cross(tangent, u); /* u x v = tangent */
        float r = radius * (1.0f - 0.4f * t);
        for (int i = 0; i <= TRUNK_SIDES; i++) {
            float a = 2.0f * (float)M_PI * (float)(i % TRUNK_SIDES) / TRUNK_SIDES;
            vec3 radial = v3_add(v3_scale(u, cosf(a)), v3_scale(v, sinf(a)));
            mesh_add_vertex(m, v3_madd(centre, radial, r), radial, (float)i / TRUNK_SIDES, t);
        }
    }
    uint32_t row = TRUNK_SIDES + 1;
    for (uint32_t k = 0; k < TRUNK_SEGMENTS; k++) {
        for (uint32_t i = 0; i < TRUNK_SIDES; i++) {
            uint32_t b0 = first + k * row + i, b1 = b0 + 1, t0 = b0 + row, t1 = t0 + 1;
            /* The angle grows counter-clockwise seen from the tangent, so this faces outward. */
            mesh_add_triangle(m, b0, b1, t1, material);
            mesh_add_triangle(m, b0, t1, t0, material);
        }
    }
    /* Top cap (the base is buried in the sand and needs none). */
    uint32_t cap = (uint32_t)m->vertex_count;
    vec3 v = v3_cross(tangent, u);
    float r = radius * 0.6f;
    for (int i = 0; i < TRUNK_SIDES; i++) {
        float a = 2.0f * (float)M_PI * (float)i / TRUNK_SIDES;
        vec3 radial = v3_add(v3_scale(u, cosf(a)), v3_scale(v, sinf(a)));
        mesh_add_vertex(m, v3_madd(centre, radial, r), tangent, 0.5f + 0.5f * cosf(a), 0.5f + 0.5f * sinf(a));
    }
    for (uint32_t i = 1; i + 1 < TRUNK_SIDES; i++)
        mesh_add_triangle(m, cap, cap + i, cap + i + 1, material);
    return centre;
}

/* A frond: a strip along a spine that leaves the crown rising and bends down under its own weight,
 * widest in the middle and ending in a point. Normals follow the curved strip (side x tangent,
 * which points up for an outward-going spine). */
static void add_frond(mesh *m, vec3 crown, float azimuth, float length, float rise, float droop, float width,
                      uint32_t material)
{
    vec3 out = v3(cosf(azimuth), 0, sinf(azimuth));
    vec3 side = v3(-sinf(azimuth), 0, cosf(azimuth)); /* side x out = up */
    vec3 up = v3(0, 1, 0);
    uint32_t first = (uint32_t)m->vertex_count;
    vec3 spine = crown;
    float step = length / FROND_SEGMENTS;
    for (int k = 0; k <= FROND_SEGMENTS; k++) {
        float s = (float)k / FROND_SEGMENTS;
        float angle = rise - droop * s;
        vec3 tangent = v3_add(v3_scale(out, cosf(angle)), v3_scale(up, sinf(angle)));
        vec3 n = v3_normalize(v3_cross(side, tangent));
        if (k == FROND_SEGMENTS) {
            mesh_add_vertex(m, spine, n, 0.5f, 1.0f); /* the pointed tip */
            break;
        }
        float w = width * (0.25f + 0.75f * sinf((float)M_PI * s));
        mesh_add_vertex(m, v3_madd(spine, side, -w), n, 0.0f, s);
        mesh_add_vertex(m, v3_madd(spine, side, w), n, 1.0f, s);
        spine = v3_madd(spine, tangent, step);
    }
    for (uint32_t k = 0; k + 1 < FROND_SEGMENTS; k++) {
        uint32_t l0 = first + 2 * k, r0 = l0 + 1, l1 = l0 + 2, r1 = l0 + 3;
        mesh_add_triangle(m, l0, r0, l1, material);
        mesh_add_triangle(m, r0, r1, l1, material);
    }
    uint32_t tip = first + 2 * FROND_SEGMENTS, l = tip - 2, r = tip - 1;
    mesh_add_triangle(m, l, r, tip, material);
}

static void add_palm(mesh *m, rng *r, vec3 base, float scale, const uint32_t *slots)
{
    /* Palms lean roughly away from the island's centre, toward the sea, as real ones do. */
    float away = atan2f(base.z, base.x) + 1.4f * (rng_float(r) - 0.5f);
    vec3 lean_dir = v3(cosf(away), 0, sinf(away));
    float length = (1.4f + 0.6f * rng_float(r)) * scale;
    float lean = 0.2f + 0.3f * rng_float(r);
    vec3 top = add_palm_trunk(m, base, lean_dir, length, lean, 0.1f * scale, slots[SLOT_TRUNK]);
    int fronds = 7 + (int)(rng_float(r) * 3.0f);
    float azimuth0 = 2.0f * (float)M_PI * rng_float(r);
    for (int f = 0; f < fronds; f++) {
        float azimuth = azimuth0 + 2.0f * (float)M_PI * ((float)f + 0.3f * (rng_float(r) - 0.5f)) / (float)fronds;
        float frond_length = (0.9f + 0.4f * rng_float(r)) * scale;
        float rise = (15.0f + 25.0f * rng_float(r)) * (float)M_PI / 180.0f;
        float droop = (80.0f + 40.0f * rng_float(r)) * (float)M_PI / 180.0f;
        add_frond(m, top, azimuth, frond_length, rise, droop, 0.14f * scale, slots[SLOT_FROND]);
    }
}

/* Palms stand on dry land between the beach and the hilltop, at least `spacing` apart. Candidates
 * are rejection-sampled; when the island has no room left the spacing relaxes, and a palm that
 * still finds no dry ground is left out rather than planted in the sea. */
static void add_palms(mesh *m, const value_noise *n, const island_params *p, uint64_t seed, const uint32_t *slots)
{
    rng r = rng_seed(seed, 2);
    float scale = (float)p->size / 12.0f, half = 0.5f * (float)p->size, height = (float)p->height;
    float spacing = 1.2f * scale;
    vec3 planted[64];
    int count = 0;
    for (int attempt = 0; count < p->palms && attempt < 4000; attempt++) {
        if (attempt % 500 == 499)
            spacing *= 0.7f;
        float x = (2.0f * rng_float(&r) - 1.0f) * half * 0.8f;
        float z = (2.0f * rng_float(&r) - 1.0f) * half * 0.8f;
        float y = terrain_height(n, p, x, z);
        if (y < 0.06f * height || y > 0.6f * height)
            continue;
        int crowded = 0;
        for (int i = 0; i < count; i++) {
            float dx = x - planted[i].x, dz = z - planted[i].z;
            crowded |= dx * dx + dz * dz < spacing * spacing;
        }
        if (crowded)
            continue;
        planted[count++] = v3(x, y, z);
        /* Sink the base a little: the mesh is a piecewise-linear version of terrain_height. */
        add_palm(m, &r, v3(x, y - 0.08f * scale, z), scale, slots);
    }
}

static int island_generate(const cJSON *params, const char *where, uint64_t seed, const uint32_t *slot_materials,
                           mesh *out, vx_err *e)
{
    island_params p;
    if (!where)
        where = "params";
    if (read_params(params, where, &p, e))
        return -1;

    value_noise noise;
    noise_init(&noise, seed, (float)p.size);
    add_terrain(out, &noise, &p, slot_materials[SLOT_SAND]);
    float s = 0.5f * (float)p.sea_size;
    mesh_add_quad(out, v3(-s, 0, s), v3(s, 0, s), v3(s, 0, -s), v3(-s, 0, -s), slot_materials[SLOT_SEA]);
    add_palms(out, &noise, &p, seed, slot_materials);
    noise_free(&noise);
    return 0;
}

const scene_generator generator_island = {
    .name = "island",
    .description = "noise height-field island in a sea plane with curved palm trees (params: resolution, palms, "
                   "size, height, sea_size)",
    .slots = island_slots,
    .generate = island_generate,
};
