/* "city": a grid of blocks of box buildings on a ground quad, separated by streets, each facade
 * covered in a regular pattern of small window boxes standing slightly proud of the wall. The
 * windows are finer than a voxel at 128^3 and regular, so a voxel sees a sub-voxel relief with a
 * strong preferred orientation: a stress test for filtering of hard-edged, axis-aligned detail. */
#include <math.h>

#include "generator.h"
#include "json_util.h"
#include "rng.h"

enum { SLOT_GROUND, SLOT_BUILDING, SLOT_WINDOW };
static const char *const city_slots[] = {"ground", "building", "window", NULL};

typedef struct {
    int blocks;
    double size, street_width, max_height;
    /* Window size and spacing as a fraction of the default: windows per facade grow as its inverse
     * square (the large city's detail, issue 19). */
    double window_scale;
} city_params;

/* Box faces in mesh_add_box's order; a window box leaves out the face against the wall. */
enum { FACE_NEG_X, FACE_POS_X, FACE_NEG_Y, FACE_POS_Y, FACE_NEG_Z, FACE_POS_Z, FACE_NONE };

static int read_params(const cJSON *params, const char *where, city_params *p, vx_err *e)
{
    static const char *const known[] = {"blocks", "size", "street_width", "max_height", "window_scale", NULL};
    p->blocks = 6;
    p->size = 12.0;
    p->street_width = -1.0; /* defaults below depend on size */
    p->max_height = -1.0;
    p->window_scale = 1.0;
    if (params && !cJSON_IsObject(params))
        return vx_fail(e, "%s: expected an object of parameters", where);
    if (json_only_fields(params, where, known, e) || json_int_in(params, "blocks", where, 1, 32, &p->blocks, e) ||
        json_number_in(params, "size", where, 1.0, 1000.0, &p->size, e) ||
        json_number_in(params, "window_scale", where, 0.05, 1.0, &p->window_scale, e))
        return -1;
    double pitch = p->size / p->blocks;
    p->street_width = 0.2 * pitch;
    p->max_height = 0.35 * p->size;
    /* A block must keep room for its 2x2 lots of at least window-sized buildings. */
    if (json_number_in(params, "street_width", where, 0.0, 0.6 * pitch, &p->street_width, e) ||
        json_number_in(params, "max_height", where, 0.05 * p->size, 2.0 * p->size, &p->max_height, e))
        return -1;
    return 0;
}

/* mesh_add_box without one face (FACE_NONE keeps all six). */
static void add_box_without(mesh *m, vec3 lo, vec3 hi, int skip_face, uint32_t material)
{
    vec3 p[8];
    for (int k = 0; k < 8; k++)
        p[k] = v3(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z);
    /* Corners indexed by bits (x, y, z); each face counter-clockwise seen from outside. */
    static const int faces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                    {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
    for (int f = 0; f < 6; f++)
        if (f != skip_face)
            mesh_add_quad(m, p[faces[f][0]], p[faces[f][1]], p[faces[f][2]], p[faces[f][3]], material);
}

/* Window geometry, all proportional to the city's scale (size / 12). At the default size a window
 * is 0.07 x 0.09 units: under the 0.094-unit voxel of a 128^3 grid over the city. */
typedef struct {
    float width, height, proud, embed, column_pitch, floor_pitch, first_floor, top_margin;
} window_style;

static window_style window_style_for(float scale)
{
    window_style w = {
        .width = 0.07f * scale,
        .height = 0.09f * scale,
        .proud = 0.02f * scale,
        /* Sunk into the wall so the open back face is hidden and no face is coplanar with the wall. */
        .embed = 0.005f * scale,
        .column_pitch = 0.16f * scale,
        .floor_pitch = 0.2f * scale,
        .first_floor = 0.25f * scale,
        .top_margin = 0.1f * scale,
    };
    return w;
}

/* Windows on one facade. The facade lies in the plane axis = plane (axis 0 = x, 2 = z), faces
 * `outward` (+1/-1) and spans [lo, hi] along the other horizontal axis; windows fill whole columns
 * and floors, centred. */
static void add_facade_windows(mesh *m, const window_style *w, int axis, float plane, int outward, float lo, float hi,
                               float top, uint32_t material)
{
    int columns = (int)floorf((hi - lo - w->column_pitch + w->width) / w->column_pitch) + 1;
    int floors = (int)floorf((top - w->top_margin - w->first_floor - w->height) / w->floor_pitch) + 1;
    if (hi - lo < w->width * 2.0f || columns < 1 || floors < 1)
        return;
    float start = 0.5f * (lo + hi) - 0.5f * (float)(columns - 1) * w->column_pitch;
    float inner = plane - (float)outward * w->embed, outer = plane + (float)outward * w->proud;
    float depth_lo = fminf(inner, outer), depth_hi = fmaxf(inner, outer);
    int skip = axis == 0 ? (outward > 0 ? FACE_NEG_X : FACE_POS_X) : (outward > 0 ? FACE_NEG_Z : FACE_POS_Z);
    for (int f = 0; f < floors; f++) {
        float y0 = w->first_floor + (float)f * w->floor_pitch;
        for (int c = 0; c < columns; c++) {
            float centre = start + (float)c * w->column_pitch;
            float a = centre - 0.5f * w->width, b = centre + 0.5f * w->width;
            vec3 box_lo = axis == 0 ? v3(depth_lo, y0, a) : v3(a, y0, depth_lo);
            vec3 box_hi = axis == 0 ? v3(depth_hi, y0 + w->height, b) : v3(b, y0 + w->height, depth_hi);
            add_box_without(m, box_lo, box_hi, skip, material);
        }
    }
}

static void add_building(mesh *m, rng *r, const window_style *w, float x0, float z0, float x1, float z1, float height,
                         float scale, const uint32_t *slots)
{
    /* Narrow streets in a many-block city can leave no room for a lot: skip it rather than emit an
     * inside-out box. */
    if (x1 - x0 < 0.02f * scale || z1 - z0 < 0.02f * scale)
        return;
    /* Starts just under the sidewalk top so its base is neither visible nor coplanar with it. */
    add_box_without(m, v3(x0, 0.01f * scale, z0), v3(x1, height, z1), FACE_NONE, slots[SLOT_BUILDING]);
    add_facade_windows(m, w, 0, x1, +1, z0, z1, height, slots[SLOT_WINDOW]);
    add_facade_windows(m, w, 0, x0, -1, z0, z1, height, slots[SLOT_WINDOW]);
    add_facade_windows(m, w, 2, z1, +1, x0, x1, height, slots[SLOT_WINDOW]);
    add_facade_windows(m, w, 2, z0, -1, x0, x1, height, slots[SLOT_WINDOW]);
    /* Some roofs carry a plant room: breaks up the silhouettes and casts small roof shadows. */
    if (rng_float(r) < 0.4f) {
        float fx = 0.25f + 0.2f * rng_float(r), fz = 0.25f + 0.2f * rng_float(r);
        float cx = 0.5f * (x0 + x1), cz = 0.5f * (z0 + z1);
        float hx = fx * (x1 - x0), hz = fz * (z1 - z0);
        float rise = (0.1f + 0.15f * rng_float(r)) * scale;
        add_box_without(m, v3(cx - hx, height - 0.01f * scale, cz - hz), v3(cx + hx, height + rise, cz + hz),
                        FACE_NONE, slots[SLOT_BUILDING]);
    }
}

static int city_generate(const cJSON *params, const char *where, uint64_t seed, const uint32_t *slot_materials,
                         mesh *out, vx_err *e)
{
    city_params p;
    if (!where)
        where = "params";
    if (read_params(params, where, &p, e))
        return -1;

    float size = (float)p.size, half = 0.5f * size, scale = size / 12.0f;
    float pitch = size / (float)p.blocks, street = (float)p.street_width;
    /* The ground extends half a street past the outer blocks, so the city has a street all round. */
    float g = half + 0.5f * street;
    mesh_add_quad(out, v3(-g, 0, g), v3(g, 0, g), v3(g, 0, -g), v3(-g, 0, -g), slot_materials[SLOT_GROUND]);

    /* window_scale 1 multiplies by exactly 1.0f: the default city is bit-identical to the one before
     * the parameter existed. */
    window_style w = window_style_for(scale * (float)p.window_scale);
    float curb = 0.02f * scale, alley = 0.08f * scale, setback = 0.04f * scale;
    for (int bz = 0; bz < p.blocks; bz++) {
        for (int bx = 0; bx < p.blocks; bx++) {
            rng r = rng_seed(seed, (uint64_t)(bz * p.blocks + bx));
            float x0 = -half + (float)bx * pitch + 0.5f * street, x1 = x0 + pitch - street;
            float z0 = -half + (float)bz * pitch + 0.5f * street, z1 = z0 + pitch - street;
            /* The sidewalk: a low slab that makes the street grid read in shading and shadows. */
            add_box_without(out, v3(x0, -0.01f * scale, z0), v3(x1, curb, z1), FACE_NEG_Y, slot_materials[SLOT_GROUND]);

            /* Downtown is taller: heights fall off with distance from the centre. */
            float cx = 0.5f * (x0 + x1), cz = 0.5f * (z0 + z1);
            float d = fminf(sqrtf(cx * cx + cz * cz) / half, 1.0f);
            float max_h = (float)p.max_height * (1.0f - 0.6f * d);
            float min_h = fminf(0.5f * scale, max_h);
            if (rng_float(&r) < 0.2f) { /* one building filling the block */
                float u = rng_float(&r);
                add_building(out, &r, &w, x0 + setback, z0 + setback, x1 - setback, z1 - setback,
                             min_h + (max_h - min_h) * u * u, scale, slot_materials);
                continue;
            }
            float xm = 0.5f * (x0 + x1), zm = 0.5f * (z0 + z1);
            for (int lot = 0; lot < 4; lot++) {
                if (rng_float(&r) < 0.12f) /* an empty lot: a small square */
                    continue;
                float lx0 = lot & 1 ? xm + 0.5f * alley : x0 + setback;
                float lx1 = lot & 1 ? x1 - setback : xm - 0.5f * alley;
                float lz0 = lot & 2 ? zm + 0.5f * alley : z0 + setback;
                float lz1 = lot & 2 ? z1 - setback : zm - 0.5f * alley;
                float u = rng_float(&r);
                add_building(out, &r, &w, lx0, lz0, lx1, lz1, min_h + (max_h - min_h) * u * u, scale, slot_materials);
            }
        }
    }
    return 0;
}

const scene_generator generator_city = {
    .name = "city",
    .description = "grid of city blocks of box buildings with sub-voxel window boxes on every facade (params: "
                   "blocks, size, street_width, max_height, window_scale)",
    .slots = city_slots,
    .generate = city_generate,
};
