/* Precomputed shadows (tracer/shadows/, issue 18) against expectations worked out by hand: a stack
 * of n horizontal leaf quads of σ = 0.25 over an opaque ground, lit from straight above (an
 * orthographic slicemap) and by a point light above the stack (a perspective one). A point between
 * quads k and k+1 has n - k quads between it and the light, so its transmittance is the paper's
 * (1 - σ)^(n-k) (Eisemann & Décoret §3.1), exactly as pow computes it up to float rounding; below
 * the opaque ground it is 0. Also: a point light inside the scene is refused naming the light; the
 * cache serves the same maps twice and builds again when the light moves; nothing is built when the
 * scene does not declare shadows. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "shadow_set.h"
#include "unit.h"

#define SIGMA 0.25f

static char dir[] = "/tmp/voxlab_unit_shadows_XXXXXX";

static int load(scene *s, int n, const char *light, int effects_shadows, vx_err *e)
{
    char text[4096], path[256];
    int k = snprintf(text, sizeof text,
                     "{\"effects\": [%s], \"lights\": [%s], \"camera\": {\"position\": [0, 3, 9], \"look_at\": [0, 1, 0]},"
                     " \"materials\": {\"leaf\": {\"shadow_sigma\": %g, \"double_sided\": true}, \"ground\": {}},"
                     " \"objects\": [{\"obj\": \"quad.obj\", \"material\": \"ground\","
                     " \"transform\": {\"scale\": 2}}",
                     effects_shadows ? "\"shadows\"" : "", light, (double)SIGMA);
    for (int i = 1; i <= n; i++)
        k += snprintf(text + k, sizeof text - (size_t)k,
                      ", {\"obj\": \"quad.obj\", \"material\": \"leaf\", \"transform\": {\"translate\": [0, %d, 0]}}",
                      i);
    snprintf(text + k, sizeof text - (size_t)k, "]}");
    snprintf(path, sizeof path, "%s/scene.json", dir);
    return scene_load_text(text, path, s, e);
}

static void stack_checks(const char *what, const char *light, int n)
{
    scene s;
    vx_err e;
    char name[160];
    if (load(&s, n, light, 1, &e)) {
        printf("not ok %s: loading: %s\n", what, e.msg);
        unit_failures++;
        return;
    }
    shadow_request r = {SHADOW_SLICEMAP, 64, 2, NULL};
    const shadow_set *set = NULL;
    shadow_stats st;
    int rc = shadow_prepare(&s, NULL, NULL, NULL, &r, &set, &st, &e);
    snprintf(name, sizeof name, "%s: the slicemap is built", what);
    CHECK(name, rc == 0 && set && st.method == SHADOW_SLICEMAP && st.bytes == set->bytes && st.build_seconds > 0);
    if (rc || !set) {
        scene_free(&s);
        return;
    }
    shadow_maps sm;
    shadow_set_view(set, &sm);
    for (int k = 0; k <= n; k++) {
        /* Between quad k and quad k + 1 (quad 0: the ground), off the columns' centres. */
        vec3 p = v3(0.137f, (float)k + 0.5f, -0.211f);
        float T = shadow_maps_transmittance(&sm, 0, p, 0.0f);
        float want = powf(1.0f - SIGMA, (float)(n - k));
        snprintf(name, sizeof name, "%s: (1 - sigma)^%d above y = %.1f", what, n - k, p.y);
        CHECK_NEAR(name, T, want, 2e-6 * want);
    }
    snprintf(name, sizeof name, "%s: (1 - sigma)^%d on the ground", what, n);
    CHECK_NEAR(name, shadow_maps_transmittance(&sm, 0, v3(0.5f, 0.0f, 0.5f), 0.0f), powf(1.0f - SIGMA, (float)n),
               2e-6);
    snprintf(name, sizeof name, "%s: 0 below the opaque ground", what);
    CHECK_NEAR(name, shadow_maps_transmittance(&sm, 0, v3(0.3f, -0.4f, 0.2f), 0.0f), 0.0f, 0.0);
    snprintf(name, sizeof name, "%s: 1 beside the stack", what);
    CHECK_NEAR(name, shadow_maps_transmittance(&sm, 0, v3(1.7f, 0.05f, 1.7f), 0.0f), 1.0f, 0.0);
    snprintf(name, sizeof name, "%s: a skip ignores the quad just above", what);
    CHECK_NEAR(name, shadow_maps_transmittance(&sm, 0, v3(0.137f, (float)n - 0.5f, 0.1f), 0.6f), 1.0f, 0.0);
    snprintf(name, sizeof name, "%s: every query counted", what);
    CHECK(name, sm.queries == (uint64_t)n + 5);
    shadow_release(set);
    scene_free(&s);
}

int main(void)
{
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    char path[256];
    snprintf(path, sizeof path, "%s/quad.obj", dir);
    FILE *f = fopen(path, "w");
    if (!f)
        return 1;
    fputs("v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nvn 0 1 0\nf 1//1 2//1 3//1 4//1\n", f);
    fclose(f);

    const char *sun = "{\"type\": \"directional\", \"direction\": [0, 1, 0]}";
    stack_checks("directional, 1 quad", sun, 1);
    stack_checks("directional, 5 quads", sun, 5);
    stack_checks("point light, 4 quads", "{\"type\": \"point\", \"position\": [0.05, 14, -0.03]}", 4);

    scene s;
    vx_err e;
    shadow_stats st;
    const shadow_set *set = NULL, *again = NULL;
    shadow_request r = {SHADOW_SLICEMAP, 32, 1, NULL};
    if (load(&s, 2, "{\"type\": \"point\", \"position\": [0, 1.5, 0]}", 1, &e) == 0) {
        int rc = shadow_prepare(&s, NULL, NULL, NULL, &r, &set, &st, &e);
        CHECK("a point light inside the scene is refused, naming the light",
              rc != 0 && !set && strstr(e.msg, "lights[0]") && strstr(e.msg, "cube of six"));
        scene_free(&s);
    }
    if (load(&s, 2, sun, 1, &e) == 0) {
        shadow_cache_clear();
        shadow_stats st2;
        int rc = shadow_prepare(&s, NULL, NULL, NULL, &r, &set, &st, &e);
        rc |= shadow_prepare(&s, NULL, NULL, NULL, &r, &again, &st2, &e);
        CHECK("the cache serves the same maps again", rc == 0 && set && set == again && !st.cache_hit &&
                                                          st2.cache_hit && st2.build_seconds == 0.0);
        shadow_release(again);
        s.lights[0].direction = v3_normalize(v3(0.3f, 1.0f, 0.0f)); /* the light moved */
        rc = shadow_prepare(&s, NULL, NULL, NULL, &r, &again, &st2, &e);
        CHECK("a moved light builds new maps", rc == 0 && again && again != set && !st2.cache_hit &&
                                                   st2.build_seconds > 0.0 &&
                                                   again->params.map[0].w.x < -0.2f);
        shadow_release(again);
        shadow_release(set);
        r.method = SHADOW_SLICEMAP_MODEL;
        rc = shadow_prepare(&s, NULL, NULL, NULL, &r, &set, &st, &e);
        CHECK("slicemap-model without a model is refused", rc != 0 && strstr(e.msg, "slicemap-model"));
        r.method = SHADOW_MARCH;
        rc = shadow_prepare(&s, NULL, NULL, NULL, &r, &set, &st, &e);
        CHECK("march builds nothing", rc == 0 && !set && st.method == SHADOW_MARCH && st.bytes == 0);
        scene_free(&s);
    }
    if (load(&s, 2, sun, 0, &e) == 0) {
        r.method = SHADOW_SLICEMAP;
        int rc = shadow_prepare(&s, NULL, NULL, NULL, &r, &set, &st, &e);
        CHECK("nothing is built when the scene does not declare shadows",
              rc == 0 && !set && st.method == -1 && st.bytes == 0 && st.build_seconds == 0.0);
        scene_free(&s);
    }
    shadow_cache_clear();
    remove(path);
    snprintf(path, sizeof path, "%s", dir);
    rmdir(path);
    return unit_exit();
}
