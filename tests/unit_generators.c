/* Procedural scene generators: every generator in generator_all() must give a sane, deterministic
 * mesh at its defaults and reject bad params with messages naming the field; then checks specific
 * to each generator (spheres are spheres, the height field has the statistics it promises, ...). */
#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "generator.h"
#include "heightfield.h"
#include "rng.h"
#include "unit.h"

enum { MAX_SLOTS = 16, SLOT_MATERIAL_BASE = 100 };

static uint32_t slot_materials[MAX_SLOTS];

static double now_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Runs a generator with params given as JSON text (NULL = defaults). */
static int run(const scene_generator *g, const char *params_json, uint64_t seed, mesh *m, vx_err *e)
{
    memset(m, 0, sizeof *m);
    cJSON *params = params_json ? cJSON_Parse(params_json) : NULL;
    if (params_json && !params) {
        fprintf(stderr, "test bug: bad JSON %s\n", params_json);
        exit(2);
    }
    int rc = g->generate(params, "test.params", seed, slot_materials, m, e);
    cJSON_Delete(params);
    return rc;
}

static int slot_count(const scene_generator *g)
{
    int n = 0;
    while (g->slots[n])
        n++;
    return n;
}

static int slot_index(const scene_generator *g, const char *slot)
{
    for (int i = 0; g->slots[i]; i++)
        if (strcmp(g->slots[i], slot) == 0)
            return i;
    return -1;
}

static size_t triangles_in_slot(const scene_generator *g, const mesh *m, const char *slot)
{
    int s = slot_index(g, slot);
    size_t n = 0;
    for (size_t t = 0; t < m->triangle_count; t++)
        n += s >= 0 && m->materials[t] == slot_materials[s];
    return n;
}

static vec3 position(const mesh *m, uint32_t v) { return mesh_position(m, v); }
static vec3 normal_of(const mesh *m, uint32_t v)
{
    return v3(m->normals[3 * v], m->normals[3 * v + 1], m->normals[3 * v + 2]);
}

/* Geometry every generator must produce: finite, indexed correctly, no zero-area triangles, unit
 * normals on the triangles' front sides, only the given slot materials (each used), plausible
 * bounds and colours. */
static void check_mesh_sane(const scene_generator *g, const char *label, const mesh *m, int at_defaults)
{
    char name[200];
    const char *gn = label;
    snprintf(name, sizeof name, "%s: has triangles", gn);
    CHECK(name, m->triangle_count > 0 && m->vertex_count > 0);

    size_t bad_position = 0, bad_normal = 0, bad_uv = 0, bad_color = 0;
    vec3 lo = v3(INFINITY, INFINITY, INFINITY), hi = v3(-INFINITY, -INFINITY, -INFINITY);
    for (size_t v = 0; v < m->vertex_count; v++) {
        vec3 p = position(m, (uint32_t)v), n = normal_of(m, (uint32_t)v);
        if (!isfinite(p.x) || !isfinite(p.y) || !isfinite(p.z))
            bad_position++;
        else {
            lo = v3_min(lo, p);
            hi = v3_max(hi, p);
        }
        double len = sqrt((double)n.x * n.x + (double)n.y * n.y + (double)n.z * n.z);
        if (!(fabs(len - 1.0) < 1e-4))
            bad_normal++;
        if (!isfinite(m->uvs[2 * v]) || !isfinite(m->uvs[2 * v + 1]))
            bad_uv++;
        for (int c = 0; c < 3; c++)
            if (!(m->colors[3 * v + c] >= 0.0f && m->colors[3 * v + c] <= 1.0f))
                bad_color++;
    }
    snprintf(name, sizeof name, "%s: positions finite", gn);
    CHECK(name, bad_position == 0);
    snprintf(name, sizeof name, "%s: normals unit length", gn);
    CHECK(name, bad_normal == 0);
    snprintf(name, sizeof name, "%s: uvs finite", gn);
    CHECK(name, bad_uv == 0);
    snprintf(name, sizeof name, "%s: vertex colours in [0, 1]", gn);
    CHECK(name, bad_color == 0);

    size_t bad_index = 0, zero_area = 0, back_facing = 0, bad_material = 0;
    int slots = slot_count(g);
    size_t per_slot[MAX_SLOTS] = {0};
    for (size_t t = 0; t < m->triangle_count; t++) {
        const uint32_t *tri = &m->indices[3 * t];
        if (tri[0] >= m->vertex_count || tri[1] >= m->vertex_count || tri[2] >= m->vertex_count) {
            bad_index++;
            continue;
        }
        vec3 a = position(m, tri[0]), b = position(m, tri[1]), c = position(m, tri[2]);
        double e1[3] = {(double)b.x - a.x, (double)b.y - a.y, (double)b.z - a.z};
        double e2[3] = {(double)c.x - a.x, (double)c.y - a.y, (double)c.z - a.z};
        double cr[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        double twice_area = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
        if (!(twice_area > 1e-12))
            zero_area++;
        /* Counter-clockwise = front: the winding normal must agree with the shading normals. */
        vec3 ns = v3_add(v3_add(normal_of(m, tri[0]), normal_of(m, tri[1])), normal_of(m, tri[2]));
        if (cr[0] * ns.x + cr[1] * ns.y + cr[2] * ns.z <= 0.0)
            back_facing++;
        int s = (int)m->materials[t] - SLOT_MATERIAL_BASE;
        if (s < 0 || s >= slots)
            bad_material++;
        else
            per_slot[s]++;
    }
    snprintf(name, sizeof name, "%s: indices in range", gn);
    CHECK(name, bad_index == 0);
    snprintf(name, sizeof name, "%s: no zero-area triangles", gn);
    CHECK(name, zero_area == 0);
    if (back_facing)
        printf("# %s: %zu of %zu triangles wound against their normals\n", gn, back_facing, m->triangle_count);
    snprintf(name, sizeof name, "%s: winding agrees with normals", gn);
    CHECK(name, back_facing == 0);
    snprintf(name, sizeof name, "%s: materials are slot materials", gn);
    CHECK(name, bad_material == 0);
    /* Unusual params may legitimately leave a slot empty (no leaves, no palms). */
    for (int s = 0; s < slots && at_defaults; s++) {
        snprintf(name, sizeof name, "%s: slot %s used", gn, g->slots[s]);
        CHECK(name, per_slot[s] > 0);
    }

    double extent = fmax(hi.x - lo.x, fmax(hi.y - lo.y, hi.z - lo.z));
    printf("# %s: bounds (%.3g %.3g %.3g) .. (%.3g %.3g %.3g)\n", gn, lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
    if (at_defaults) {
        snprintf(name, sizeof name, "%s: bounds plausible", gn);
        CHECK(name, extent > 0.5 && extent < 500.0 && lo.y > -0.2 * extent && hi.y > 0.0 && hi.y < extent);
    }
}

static int same_mesh(const mesh *a, const mesh *b)
{
    if (a->vertex_count != b->vertex_count || a->triangle_count != b->triangle_count)
        return 0;
    size_t nv = a->vertex_count, nt = a->triangle_count;
    return memcmp(a->positions, b->positions, 3 * nv * sizeof(float)) == 0 &&
           memcmp(a->normals, b->normals, 3 * nv * sizeof(float)) == 0 &&
           memcmp(a->uvs, b->uvs, 2 * nv * sizeof(float)) == 0 &&
           memcmp(a->colors, b->colors, 3 * nv * sizeof(float)) == 0 &&
           memcmp(a->indices, b->indices, 3 * nt * sizeof(uint32_t)) == 0 &&
           memcmp(a->materials, b->materials, nt * sizeof(uint32_t)) == 0;
}

static int positions_differ(const mesh *a, const mesh *b)
{
    return a->vertex_count != b->vertex_count ||
           memcmp(a->positions, b->positions, 3 * a->vertex_count * sizeof(float)) != 0;
}

/* Each generator's out-of-range case: a param and a value outside its range. A generator missing
 * here fails its check, so new generators get one. */
static const struct {
    const char *generator, *field, *params;
} out_of_range[] = {
    {"spheres", "count", "{\"count\": 0}"},
    {"trees", "leaf_size", "{\"leaf_size\": -0.1}"},
    {"tree", "leaves", "{\"leaves\": -1}"},
    {"island", "resolution", "{\"resolution\": 3}"},
    {"city", "street_width", "{\"street_width\": 100}"},
    {"city", "window_scale", "{\"window_scale\": 0.01}"},
    {"heightfield", "sigma_h", "{\"sigma_h\": -1}"},
};

static void check_params_rejected(const scene_generator *g)
{
    char name[160];
    mesh m;
    vx_err e = {{0}};
    int rc = run(g, "{\"no_such_param\": 1}", 1, &m, &e);
    mesh_free(&m);
    snprintf(name, sizeof name, "%s: unknown param is an error naming it", g->name);
    CHECK(name, rc != 0 && strstr(e.msg, "no_such_param") && strstr(e.msg, "test.params"));

    e.msg[0] = 0;
    rc = run(g, "[1, 2]", 1, &m, &e);
    mesh_free(&m);
    snprintf(name, sizeof name, "%s: params that are not an object are an error", g->name);
    CHECK(name, rc != 0 && e.msg[0] != 0);

    const char *field = NULL, *params = NULL;
    for (size_t i = 0; i < sizeof out_of_range / sizeof out_of_range[0]; i++)
        if (strcmp(out_of_range[i].generator, g->name) == 0) {
            field = out_of_range[i].field;
            params = out_of_range[i].params;
        }
    snprintf(name, sizeof name, "%s: has an out-of-range case in this test", g->name);
    CHECK(name, field != NULL);
    if (!field)
        return;
    e.msg[0] = 0;
    rc = run(g, params, 1, &m, &e);
    mesh_free(&m);
    if (rc == 0 || !strstr(e.msg, field))
        printf("# %s: message was \"%s\"\n", g->name, e.msg);
    snprintf(name, sizeof name, "%s: out-of-range %s is an error naming it", g->name, field);
    CHECK(name, rc != 0 && strstr(e.msg, field) != NULL);
}

static void check_generator(const scene_generator *g)
{
    char name[160];
    mesh m, again, other;
    vx_err e = {{0}};
    double t0 = now_seconds();
    int rc = run(g, NULL, 7, &m, &e);
    double seconds = now_seconds() - t0;
    snprintf(name, sizeof name, "%s: generates with default params", g->name);
    CHECK(name, rc == 0);
    if (rc != 0) {
        printf("# %s: %s\n", g->name, e.msg);
        mesh_free(&m);
        return;
    }
    printf("# %s: %zu triangles, %zu vertices in %.1f ms\n", g->name, m.triangle_count, m.vertex_count,
           1e3 * seconds);
    check_mesh_sane(g, g->name, &m, 1);

    run(g, NULL, 7, &again, &e);
    snprintf(name, sizeof name, "%s: same seed gives bit-identical output", g->name);
    CHECK(name, same_mesh(&m, &again));
    run(g, NULL, 8, &other, &e);
    snprintf(name, sizeof name, "%s: another seed changes the output", g->name);
    CHECK(name, positions_differ(&m, &other));
    mesh_free(&again);
    mesh_free(&other);
    mesh_free(&m);

    check_params_rejected(g);
}

/* Params at the ends of their ranges must still give sane geometry (no zero-area triangles from
 * tiny features, no inside-out boxes from narrow lots, ...). */
static const struct {
    const char *generator, *params;
} extremes[] = {
    {"spheres", "{\"count\": 16, \"ground_size\": 0.5, \"segments\": 3, \"rings\": 2}"},
    {"spheres", "{\"count\": 1, \"ground_size\": 1000, \"segments\": 1024, \"rings\": 512}"},
    {"trees", "{\"count\": 256, \"leaves_per_tree\": 10, \"ground_size\": 1, \"leaf_size\": 0.0001}"},
    {"trees", "{\"count\": 1, \"leaves_per_tree\": 0, \"ground_size\": 1000, \"leaf_size\": 100}"},
    {"island", "{\"resolution\": 8, \"palms\": 64, \"size\": 1, \"height\": 0.5, \"sea_size\": 10}"},
    {"island", "{\"resolution\": 300, \"palms\": 0, \"size\": 1000, \"height\": 10, \"sea_size\": 1000}"},
    {"city", "{\"blocks\": 32, \"size\": 1, \"street_width\": 0}"},
    {"city", "{\"blocks\": 32, \"size\": 1, \"street_width\": 0.01875, \"max_height\": 2}"},
    {"city", "{\"blocks\": 1, \"size\": 1000, \"street_width\": 600, \"max_height\": 50}"},
    {"city", "{\"blocks\": 2, \"size\": 1, \"window_scale\": 0.05}"},
    {"heightfield", "{\"resolution\": 8, \"waves\": 1, \"sigma_h\": 1}"},
    {"heightfield", "{\"size\": 0.01, \"resolution\": 64, \"waves\": 8, \"mean_color\": [0, 1, 0.5], "
                    "\"delta_color\": [0, 0, -0.5]}"},
};

static void check_extremes(void)
{
    for (size_t i = 0; i < sizeof extremes / sizeof extremes[0]; i++) {
        const scene_generator *g = generator_find(extremes[i].generator);
        char label[200];
        snprintf(label, sizeof label, "%s %s", extremes[i].generator, extremes[i].params);
        mesh m;
        vx_err e = {{0}};
        int rc = g ? run(g, extremes[i].params, 2, &m, &e) : -1;
        char name[260];
        snprintf(name, sizeof name, "%s: generates", label);
        CHECK(name, rc == 0);
        if (rc == 0)
            check_mesh_sane(g, label, &m, 0);
        else
            printf("# %s\n", e.msg);
        if (g)
            mesh_free(&m);
    }
}

/* --- generator-specific checks --- */

static uint32_t find_root(uint32_t *parent, uint32_t v)
{
    while (parent[v] != v)
        v = parent[v] = parent[parent[v]];
    return v;
}

/* Sphere triangles form one connected piece per sphere; each piece's vertices must lie at one
 * radius from its centre, with normals pointing radially, and the sphere must rest on y = 0. */
static void check_spheres(void)
{
    const scene_generator *g = generator_find("spheres");
    mesh m;
    vx_err e;
    if (run(g, NULL, 3, &m, &e))
        return;
    uint32_t *parent = malloc(sizeof(uint32_t) * m.vertex_count);
    int *is_sphere = calloc(m.vertex_count, sizeof(int));
    for (uint32_t v = 0; v < m.vertex_count; v++)
        parent[v] = v;
    int s1 = slot_index(g, "sphere"), s2 = slot_index(g, "sphere2");
    for (size_t t = 0; t < m.triangle_count; t++) {
        if (m.materials[t] != slot_materials[s1] && (s2 < 0 || m.materials[t] != slot_materials[s2]))
            continue;
        const uint32_t *tri = &m.indices[3 * t];
        for (int k = 0; k < 3; k++) {
            is_sphere[tri[k]] = 1;
            parent[find_root(parent, tri[k])] = find_root(parent, tri[(k + 1) % 3]);
        }
    }
    /* Bounds per component give centre and radius (exact at the default 48 x 24 tessellation, whose
     * vertices include the axis-aligned extremes). */
    enum { MAX_COMPONENTS = 64 };
    uint32_t roots[MAX_COMPONENTS];
    vec3 lo[MAX_COMPONENTS], hi[MAX_COMPONENTS];
    int components = 0, too_many = 0;
    for (uint32_t v = 0; v < m.vertex_count; v++) {
        if (!is_sphere[v])
            continue;
        uint32_t r = find_root(parent, v);
        int c = 0;
        while (c < components && roots[c] != r)
            c++;
        if (c == components) {
            if (components == MAX_COMPONENTS) {
                too_many = 1;
                continue;
            }
            roots[components] = r;
            lo[c] = hi[c] = position(&m, v);
            components++;
        }
        lo[c] = v3_min(lo[c], position(&m, v));
        hi[c] = v3_max(hi[c], position(&m, v));
    }
    CHECK("spheres: default count of separate spheres", components == 4 && !too_many);
    double worst_radius = 0.0, worst_normal = 0.0, worst_rest = 0.0;
    for (uint32_t v = 0; v < m.vertex_count; v++) {
        if (!is_sphere[v])
            continue;
        uint32_t r = find_root(parent, v);
        int c = 0;
        while (c < components && roots[c] != r)
            c++;
        if (c == components)
            continue;
        vec3 centre = v3_scale(v3_add(lo[c], hi[c]), 0.5f);
        double radius = 0.5 * ((double)hi[c].y - lo[c].y);
        vec3 d = v3_sub(position(&m, v), centre);
        worst_radius = fmax(worst_radius, fabs(v3_length(d) - radius) / radius);
        worst_normal = fmax(worst_normal, v3_length(v3_sub(v3_scale(d, (float)(1.0 / radius)), normal_of(&m, v))));
        worst_rest = fmax(worst_rest, fabs(centre.y - radius) / radius);
    }
    CHECK_NEAR("spheres: vertices at the radius from the centre", worst_radius, 0.0, 1e-5);
    CHECK_NEAR("spheres: normals point radially", worst_normal, 0.0, 1e-5);
    CHECK_NEAR("spheres: spheres rest on the ground", worst_rest, 0.0, 1e-5);
    free(parent);
    free(is_sphere);
    mesh_free(&m);
}

static double color_channel(vec3 c, int i) { return v3_get(c, i); }

/* The mesh must sample heightfield_eval exactly; heights must have mean 0 and std sigma_h (exact
 * by construction, see heightfield.h), be close to Gaussian, and colours must follow s(h). */
static void check_heightfield(void)
{
    const scene_generator *g = generator_find("heightfield");
    const uint64_t seed = 11;
    mesh m;
    vx_err e;
    heightfield_surface s;
    if (run(g, NULL, seed, &m, &e) || heightfield_surface_init(&s, NULL, "test.params", seed, &e)) {
        CHECK("heightfield: surface and mesh", 0);
        return;
    }
    double sum = 0.0, sum2 = 0.0, within_sigma = 0.0, s_sum = 0.0;
    double worst_color = 0.0, worst_normal = 0.0;
    size_t height_mismatch = 0, n = m.vertex_count;
    for (uint32_t v = 0; v < n; v++) {
        vec3 p = position(&m, v), normal;
        double h = heightfield_eval(&s, p.x, p.z, &normal, NULL);
        height_mismatch += (float)h != p.y;
        worst_normal = fmax(worst_normal, v3_length(v3_sub(normal, normal_of(&m, v))));
        double y = p.y;
        sum += y;
        sum2 += y * y;
        within_sigma += fabs(y) <= s.sigma_h;
        /* Independent of heightfield_color: the formula from the brief. */
        double weight = erf(y / (sqrt(2.0) * s.sigma_h));
        s_sum += weight;
        for (int c = 0; c < 3; c++) {
            double want = color_channel(s.mean_color, c) + weight * color_channel(s.delta_color, c);
            worst_color = fmax(worst_color, fabs(m.colors[3 * v + c] - want));
        }
    }
    double mean = sum / (double)n, std = sqrt(sum2 / (double)n - mean * mean);
    printf("# heightfield: sigma_h %.6g, vertex mean %.3g, std %.6g, P(|h| <= sigma) %.4f, %d waves\n", s.sigma_h,
           mean, std, within_sigma / (double)n, s.wave_count);
    CHECK("heightfield: vertices sample heightfield_eval exactly", height_mismatch == 0);
    CHECK_NEAR("heightfield: vertex normals are the analytic normals", worst_normal, 0.0, 1e-6);
    CHECK_NEAR("heightfield: height mean is 0", mean / s.sigma_h, 0.0, 0.01);
    CHECK_NEAR("heightfield: height std is sigma_h", std / s.sigma_h, 1.0, 0.01);
    CHECK_NEAR("heightfield: heights near Gaussian (68% within sigma)", within_sigma / (double)n, 0.6827, 0.02);
    CHECK_NEAR("heightfield: s(h) averages 0", s_sum / (double)n, 0.0, 0.02);
    CHECK_NEAR("heightfield: colours are mean + s(h) delta", worst_color, 0.0, 1e-5);

    /* Off the grid too: the orthogonality holds for the continuous patch. */
    rng r = rng_seed(5, 0);
    double csum = 0.0, csum2 = 0.0;
    const int samples = 20000;
    for (int i = 0; i < samples; i++) {
        double x = (rng_double(&r) - 0.5) * s.size, z = (rng_double(&r) - 0.5) * s.size;
        double h = heightfield_eval(&s, x, z, NULL, NULL);
        csum += h;
        csum2 += h * h;
    }
    double cmean = csum / samples, cstd = sqrt(csum2 / samples - cmean * cmean);
    CHECK_NEAR("heightfield: random-point std is sigma_h", cstd / s.sigma_h, 1.0, 0.03);

    vec3 c_high = heightfield_color(&s, 3.0 * s.sigma_h), c_low = heightfield_color(&s, -3.0 * s.sigma_h);
    CHECK("heightfield: bumps lighter than valleys", c_high.x + c_high.y + c_high.z > c_low.x + c_low.y + c_low.z);

    /* The header's init reads params exactly as the generator does. */
    cJSON *custom_params = cJSON_Parse("{\"size\": 2, \"resolution\": 64}");
    heightfield_surface custom;
    CHECK("heightfield: init with params scales the default band",
          heightfield_surface_init(&custom, custom_params, "p", 1, &e) == 0 && custom.size == 2.0 &&
              custom.wavelength_min >= 5.0 * 2.0 / 64 - 1e-12);
    heightfield_surface_free(&custom);
    cJSON_Delete(custom_params);
    heightfield_surface_free(&s);
    mesh_free(&m);

    mesh bad;
    e.msg[0] = 0;
    int rc = run(g, "{\"delta_color\": [0.6, 0, 0]}", 1, &bad, &e);
    mesh_free(&bad);
    CHECK("heightfield: colour leaving [0, 1] is an error naming delta_color", rc != 0 && strstr(e.msg, "delta_color"));
    e.msg[0] = 0;
    rc = run(g, "{\"waves\": 1000, \"wavelength_min\": 1.0, \"wavelength_max\": 1.1}", 1, &bad, &e);
    mesh_free(&bad);
    CHECK("heightfield: too many waves for the band is an error naming waves", rc != 0 && strstr(e.msg, "waves"));
}

static void check_trees(void)
{
    const scene_generator *g = generator_find("trees");
    mesh m;
    vx_err e;
    if (run(g, NULL, 7, &m, &e))
        return;
    size_t leaves = triangles_in_slot(g, &m, "leaf");
    printf("# trees: %zu leaf triangles\n", leaves);
    CHECK("trees: at least 2000 leaf triangles", leaves >= 2000);
    mesh_free(&m);
}

static void check_city(void)
{
    const scene_generator *g = generator_find("city");
    mesh m;
    vx_err e;
    if (run(g, NULL, 7, &m, &e))
        return;
    size_t windows = triangles_in_slot(g, &m, "window");
    printf("# city: %zu window triangles\n", windows);
    CHECK("city: has windows", windows >= 1000);
    CHECK("city: at most 300k triangles at defaults", m.triangle_count <= 300000);
    mesh_free(&m);

    /* window_scale s: windows per facade grow as 1/s^2 (columns and floors each as 1/s, a little
     * faster for the whole ones that now fit), what scenes/city_large.json's 10^7 triangles rest on;
     * checked on a 2x2-block city so that it stays quick. */
    size_t w[3];
    const char *scaled[3] = {"{\"blocks\": 2, \"size\": 4}", "{\"blocks\": 2, \"size\": 4, \"window_scale\": 0.5}",
                             "{\"blocks\": 2, \"size\": 4, \"window_scale\": 0.25}"};
    for (int i = 0; i < 3; i++) {
        if (run(g, scaled[i], 7, &m, &e)) {
            printf("# %s\n", e.msg);
            w[i] = 0;
            continue;
        }
        w[i] = triangles_in_slot(g, &m, "window");
        mesh_free(&m);
    }
    printf("# city 2x2 blocks: %zu, %zu, %zu window triangles at window_scale 1, 0.5, 0.25\n", w[0], w[1], w[2]);
    CHECK("city: window_scale 0.5 gives 4 to 6 times the windows", w[0] > 0 && w[1] >= 4 * w[0] && w[1] <= 6 * w[0]);
    CHECK("city: window_scale 0.25 gives 4 to 6 times the windows of 0.5", w[2] >= 4 * w[1] && w[2] <= 6 * w[1]);
}

static void check_island(void)
{
    const scene_generator *g = generator_find("island");
    mesh m;
    vx_err e;
    if (run(g, NULL, 7, &m, &e))
        return;
    int sand = slot_index(g, "sand");
    float top = -INFINITY, bottom = INFINITY;
    for (size_t t = 0; t < m.triangle_count; t++)
        if (m.materials[t] == slot_materials[sand])
            for (int k = 0; k < 3; k++) {
                float y = m.positions[3 * m.indices[3 * t + k] + 1];
                top = fmaxf(top, y);
                bottom = fminf(bottom, y);
            }
    CHECK("island: terrain rises out of the sea and dips under it", top > 0.3f && bottom < 0.0f);
    mesh_free(&m);
}

int main(void)
{
    for (int i = 0; i < MAX_SLOTS; i++)
        slot_materials[i] = SLOT_MATERIAL_BASE + (uint32_t)i;

    const scene_generator *const *all = generator_all();
    int count = 0;
    for (const scene_generator *const *g = all; *g; g++, count++) {
        char name[160];
        snprintf(name, sizeof name, "%s: generator_find finds it", (*g)->name);
        CHECK(name, generator_find((*g)->name) == *g);
        snprintf(name, sizeof name, "%s: has slots and a description", (*g)->name);
        CHECK(name, slot_count(*g) > 0 && slot_count(*g) <= MAX_SLOTS && (*g)->description);
        check_generator(*g);
    }
    CHECK("registry: lists the five generators", count >= 5);
    CHECK("registry: unknown name gives NULL", generator_find("no-such-generator") == NULL);
    CHECK("registry: all the expected names", generator_find("spheres") && generator_find("trees") &&
                                                  generator_find("island") && generator_find("city") &&
                                                  generator_find("heightfield"));

    check_extremes();
    check_spheres();
    check_heightfield();
    check_trees();
    check_city();
    check_island();
    return unit_exit();
}
