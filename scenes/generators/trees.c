/* "trees": a procedural forest, the foliage case of Brito et al. 2023. Each tree is a tapered
 * low-poly trunk with a few branches and hundreds of small single-quad leaves with random
 * orientations clustered around the branch ends. The leaves are deliberately smaller than a pixel
 * at 128x128 of the whole scene, so a pixel (or a voxel) sees partial, direction-dependent coverage:
 * exactly what voxel appearance models have to get right. */
#include <math.h>

#include "generator.h"
#include "json_util.h"
#include "rng.h"

enum { SLOT_GROUND, SLOT_BARK, SLOT_LEAF };
static const char *const tree_slots[] = {"ground", "bark", "leaf", NULL};

typedef struct {
    int count, leaves_per_tree;
    double ground_size, leaf_size;
} trees_params;

enum { MAX_TREES = 256, MAX_BRANCHES = 6, PRISM_SIDES = 6 };

static int read_params(const cJSON *params, const char *where, trees_params *p, vx_err *e)
{
    static const char *const known[] = {"count", "leaves_per_tree", "ground_size", "leaf_size", NULL};
    p->count = 16;
    p->leaves_per_tree = 800;
    p->ground_size = 10.0;
    /* 0.065 on a 10-unit scene: about 0.6 pixel at 128x128 of the whole scene, and 0.8 of a
     * 128^3 voxel over it. Together with 800 leaves a tree's crown covers about half of what is
     * behind it: partial coverage, the hard case. */
    p->leaf_size = 0.065;
    if (params && !cJSON_IsObject(params))
        return vx_fail(e, "%s: expected an object of parameters", where);
    if (json_only_fields(params, where, known, e) ||
        json_int_in(params, "count", where, 1, MAX_TREES, &p->count, e) ||
        json_int_in(params, "leaves_per_tree", where, 0, 20000, &p->leaves_per_tree, e) ||
        json_number_in(params, "ground_size", where, 1.0, 1000.0, &p->ground_size, e) ||
        /* Relative lower bound: a leaf much smaller than the float spacing of its coordinates
         * would collapse to zero area. */
        json_number_in(params, "leaf_size", where, 1e-4 * p->ground_size, 0.1 * p->ground_size, &p->leaf_size,
                       e))
        return -1;
    return 0;
}

/* A tapered prism from p0 (radius r0) to p1 (radius r1) with smooth side normals and flat end caps.
 * Radii must be positive so no cap or side triangle degenerates. */
static void add_tapered_prism(mesh *m, vec3 p0, float r0, vec3 p1, float r1, uint32_t material)
{
    vec3 axis_vec = v3_sub(p1, p0);
    float len = v3_length(axis_vec);
    vec3 axis = v3_scale(axis_vec, 1.0f / len);
    vec3 u, v; /* u x v = axis, so increasing angle runs counter-clockwise seen from p1 */
    v3_basis(axis, &u, &v);
    /* Tilting the normal by the taper slope keeps shading consistent with the actual cone. */
    float slope = (r0 - r1) / len;
    uint32_t side = (uint32_t)m->vertex_count;
    for (int i = 0; i <= PRISM_SIDES; i++) {
        float a = 2.0f * (float)M_PI * (float)(i % PRISM_SIDES) / PRISM_SIDES;
        vec3 radial = v3_add(v3_scale(u, cosf(a)), v3_scale(v, sinf(a)));
        vec3 n = v3_normalize(v3_madd(radial, axis, slope));
        mesh_add_vertex(m, v3_madd(p0, radial, r0), n, (float)i / PRISM_SIDES, 0.0f);
        mesh_add_vertex(m, v3_madd(p1, radial, r1), n, (float)i / PRISM_SIDES, 1.0f);
    }
    for (uint32_t i = 0; i < PRISM_SIDES; i++) {
        uint32_t b0 = side + 2 * i, t0 = b0 + 1, b1 = b0 + 2, t1 = b0 + 3;
        mesh_add_triangle(m, b0, b1, t1, material);
        mesh_add_triangle(m, b0, t1, t0, material);
    }
    /* Caps as fans with their own flat-normal vertices. */
    for (int end = 0; end < 2; end++) {
        vec3 centre = end ? p1 : p0;
        float r = end ? r1 : r0;
        vec3 n = end ? axis : v3_scale(axis, -1.0f);
        uint32_t first = (uint32_t)m->vertex_count;
        for (int i = 0; i < PRISM_SIDES; i++) {
            float a = 2.0f * (float)M_PI * (float)i / PRISM_SIDES;
            vec3 radial = v3_add(v3_scale(u, cosf(a)), v3_scale(v, sinf(a)));
            mesh_add_vertex(m, v3_madd(centre, radial, r), n, 0.5f + 0.5f * cosf(a), 0.5f + 0.5f * sinf(a));
        }
        for (uint32_t i = 1; i + 1 < PRISM_SIDES; i++) {
            if (end)
                mesh_add_triangle(m, first, first + i, first + i + 1, material);
            else
                mesh_add_triangle(m, first, first + i + 1, first + i, material);
        }
    }
}

/* Uniform in the unit ball (by rejection: 52% acceptance, and exact uniformity for free). */
static vec3 random_in_ball(rng *r)
{
    for (;;) {
        vec3 p = v3(2.0f * rng_float(r) - 1.0f, 2.0f * rng_float(r) - 1.0f, 2.0f * rng_float(r) - 1.0f);
        if (v3_dot(p, p) <= 1.0f)
            return p;
    }
}

static vec3 random_direction(rng *r)
{
    for (;;) {
        vec3 p = random_in_ball(r);
        float len2 = v3_dot(p, p);
        if (len2 > 1e-4f)
            return v3_scale(p, 1.0f / sqrtf(len2));
    }
}

/* One leaf: a leaf_size x 0.6 leaf_size rectangle, centred on c, facing a uniformly random
 * direction, spun by a random angle about it. */
static void add_leaf(mesh *m, rng *r, vec3 c, float leaf_size, uint32_t material)
{
    vec3 n = random_direction(r);
    vec3 t0, b0;
    v3_basis(n, &t0, &b0);
    float spin = 2.0f * (float)M_PI * rng_float(r);
    vec3 t = v3_add(v3_scale(t0, cosf(spin)), v3_scale(b0, sinf(spin)));
    vec3 b = v3_cross(n, t); /* t x b = n: corners below run counter-clockwise seen from n */
    vec3 ht = v3_scale(t, 0.5f * leaf_size), hb = v3_scale(b, 0.3f * leaf_size);
    mesh_add_quad(m, v3_sub(v3_sub(c, ht), hb), v3_sub(v3_add(c, ht), hb), v3_add(v3_add(c, ht), hb),
                  v3_add(v3_sub(c, ht), hb), material);
}

static void add_tree(mesh *m, const trees_params *p, uint64_t seed, int index, vec3 base, float scale,
                     const uint32_t *slots)
{
    /* Each tree draws from its own stream, so one tree's shape does not depend on another's. */
    rng r = rng_seed(seed, 1000 + (uint64_t)index);
    float height = (2.0f + 1.2f * rng_float(&r)) * scale;
    float trunk_r = (0.07f + 0.03f * rng_float(&r)) * scale;
    vec3 top = v3_madd(base, v3(0, 1, 0), height * 0.8f);
    /* Start the trunk slightly below ground so its base is not coplanar with the ground quad. */
    add_tapered_prism(m, v3_madd(base, v3(0, 1, 0), -0.05f * scale), trunk_r, top, trunk_r * 0.5f, slots[SLOT_BARK]);

    vec3 clusters[MAX_BRANCHES + 1];
    float cluster_r[MAX_BRANCHES + 1];
    int branches = 4 + (int)(rng_float(&r) * 3.0f); /* 4..6 */
    float azimuth0 = 2.0f * (float)M_PI * rng_float(&r);
    for (int b = 0; b < branches; b++) {
        float along = 0.45f + 0.45f * ((float)b + 0.5f * rng_float(&r)) / (float)branches;
        vec3 start = v3_madd(base, v3(0, 1, 0), height * 0.8f * along);
        /* Golden-angle azimuths spread the branches evenly around the trunk. */
        float azimuth = azimuth0 + 2.39996f * (float)b + 0.3f * (rng_float(&r) - 0.5f);
        float elevation = (25.0f + 35.0f * rng_float(&r)) * (float)M_PI / 180.0f;
        vec3 dir = v3(cosf(elevation) * cosf(azimuth), sinf(elevation), cosf(elevation) * sinf(azimuth));
        float length = (0.55f + 0.35f * rng_float(&r)) * (1.1f - 0.5f * along) * scale;
        vec3 tip = v3_madd(start, dir, length);
        float radius = trunk_r * (0.55f - 0.2f * along);
        add_tapered_prism(m, start, radius, tip, radius * 0.4f, slots[SLOT_BARK]);
        clusters[b] = tip;
        cluster_r[b] = (0.22f + 0.1f * rng_float(&r)) * scale;
    }
    clusters[branches] = v3_madd(top, v3(0, 1, 0), 0.1f * scale);
    cluster_r[branches] = (0.28f + 0.1f * rng_float(&r)) * scale;

    int cluster_count = branches + 1;
    float leaf_size = (float)p->leaf_size;
    for (int i = 0; i < p->leaves_per_tree; i++) {
        int k = i % cluster_count;
        vec3 c = v3_madd(clusters[k], random_in_ball(&r), cluster_r[k]);
        if (c.y < leaf_size) /* never under the ground */
            c.y = leaf_size;
        add_leaf(m, &r, c, leaf_size, slots[SLOT_LEAF]);
    }
}

/* Trees go on a jittered grid: a random subset of cells (partial Fisher-Yates shuffle), each
 * jittered within its cell. Unlike rejection sampling this always finishes and never lets two
 * crowns grow into each other. */
static int trees_generate(const cJSON *params, const char *where, uint64_t seed, const uint32_t *slot_materials,
                          mesh *out, vx_err *e)
{
    trees_params p;
    if (!where)
        where = "params";
    if (read_params(params, where, &p, e))
        return -1;

    float size = (float)p.ground_size, h = 0.5f * size, scale = size / 10.0f;
    mesh_add_quad(out, v3(-h, 0, h), v3(h, 0, h), v3(h, 0, -h), v3(-h, 0, -h), slot_materials[SLOT_GROUND]);

    int grid = (int)ceil(sqrt((double)p.count));
    int cells[MAX_TREES * 2];
    for (int i = 0; i < grid * grid; i++)
        cells[i] = i;
    rng r = rng_seed(seed, 0);
    float margin = 0.9f * scale; /* about one crown radius, so leaves stay over the ground */
    float cell = (size - 2.0f * margin) / (float)grid;
    for (int t = 0; t < p.count; t++) {
        int pick = t + (int)(rng_float(&r) * (float)(grid * grid - t));
        int chosen = cells[pick];
        cells[pick] = cells[t];
        cells[t] = chosen;
        float x = -h + margin + cell * ((float)(chosen % grid) + 0.5f + 0.5f * (rng_float(&r) - 0.5f));
        float z = -h + margin + cell * ((float)(chosen / grid) + 0.5f + 0.5f * (rng_float(&r) - 0.5f));
        add_tree(out, &p, seed, t, v3(x, 0, z), scale, slot_materials);
    }
    return 0;
}

const scene_generator generator_trees = {
    .name = "trees",
    .description = "procedural forest of trunks, branches and thousands of sub-pixel leaf quads (params: count, "
                   "leaves_per_tree, ground_size, leaf_size)",
    .slots = tree_slots,
    .generate = trees_generate,
};

/* "tree": one tree of the forest above at the origin (its base at y = 0), without ground: the
 * prototype an instanced forest repeats ("instances" / "scatter", tracer/scene/instancing.h).
 * params: leaves (per tree, default 800), leaf_size (default 0.065), size (the tree's scale, 1 =
 * the forest's trees on its 10-unit ground). The seed picks the tree's shape. */
static const char *const tree_slots_one[] = {"bark", "leaf", NULL};

static int tree_generate(const cJSON *params, const char *where, uint64_t seed, const uint32_t *slot_materials,
                         mesh *out, vx_err *e)
{
    static const char *const known[] = {"leaves", "leaf_size", "size", NULL};
    trees_params p = {1, 800, 10.0, 0.065};
    double size = 1.0;
    if (!where)
        where = "params";
    if (params && !cJSON_IsObject(params))
        return vx_fail(e, "%s: expected an object of parameters", where);
    if (json_only_fields(params, where, known, e) || json_int_in(params, "leaves", where, 0, 20000, &p.leaves_per_tree, e) ||
        json_number_in(params, "size", where, 1e-3, 1e3, &size, e) ||
        json_number_in(params, "leaf_size", where, 1e-3 * size, 0.5 * size, &p.leaf_size, e))
        return -1;
    uint32_t slots[3] = {0, slot_materials[0], slot_materials[1]}; /* add_tree's ground, bark, leaf */
    add_tree(out, &p, seed, 0, v3(0, 0, 0), (float)size, slots);
    return 0;
}

const scene_generator generator_tree = {
    .name = "tree",
    .description = "one tree of the trees generator at the origin, no ground: a prototype to instance (params: "
                   "leaves, leaf_size, size)",
    .slots = tree_slots_one,
    .generate = tree_generate,
};
