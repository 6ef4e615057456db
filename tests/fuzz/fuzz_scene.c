/* libFuzzer harness: the scene JSON loader (scene_load), with everything it reaches: meshes named
 * by the scene (the fixtures beside it), textures, and the procedural generators with their params.
 *
 * Inputs whose generator params hold a number above 64 are skipped, and so is the height field at
 * its default resolution (512^2: 7 s a load under ASan): generators accept resolutions and counts up
 * to thousands (a 4096^2 height field is 33 M triangles, minutes and gigabytes under ASan), which
 * the fuzzer would otherwise report as timeouts and out-of-memory on inputs that are valid. Small
 * values still run every generator's code (run.sh seeds the height field at resolution 32). Instancing
 * multiplies an object: inputs with more than 64 instances over all objects ("instances" lists and
 * "scatter" counts) are skipped too, for the same reason (a million copies are valid, and gigabytes).
 * So are inputs that multiply triangles by a small number: "subdivide" above 1 (4^k triangles per
 * triangle) and a "window_scale" param below 0.5 (the city's windows grow as its inverse square;
 * scenes/city_large.json's 0.11 is 10^7 triangles). */
#include <cjson/cJSON.h>

#include "fuzz_common.h"
#include "scene.h"

static int has_big_number(const cJSON *j)
{
    if (cJSON_IsNumber(j))
        return !(j->valuedouble >= -64 && j->valuedouble <= 64);
    for (const cJSON *c = j ? j->child : NULL; c; c = c->next)
        if (has_big_number(c))
            return 1;
    return 0;
}

static int too_costly(const uint8_t *data, size_t size)
{
    cJSON *root = cJSON_ParseWithLength((const char *)data, size);
    int costly = 0;
    double copies = 0; /* instances over every object */
    const cJSON *objects = cJSON_GetObjectItemCaseSensitive(root, "objects");
    for (const cJSON *o = objects ? objects->child : NULL; o && !costly; o = o->next)
    {
        const cJSON *gen = cJSON_GetObjectItemCaseSensitive(o, "generator");
        const cJSON *params = cJSON_GetObjectItemCaseSensitive(o, "params");
        const cJSON *list = cJSON_GetObjectItemCaseSensitive(o, "instances");
        const cJSON *scatter = cJSON_GetObjectItemCaseSensitive(o, "scatter");
        const cJSON *count = cJSON_GetObjectItemCaseSensitive(scatter, "count");
        copies += cJSON_GetArraySize(list) + (cJSON_IsNumber(count) ? count->valuedouble : 0);
        costly = has_big_number(count) || copies > 64;
        const cJSON *subdivide = cJSON_GetObjectItemCaseSensitive(o, "subdivide");
        const cJSON *windows = cJSON_GetObjectItemCaseSensitive(params, "window_scale");
        costly = costly || (cJSON_IsNumber(subdivide) && !(subdivide->valuedouble <= 1)) ||
                 (cJSON_IsNumber(windows) && !(windows->valuedouble >= 0.5));
        costly = costly || (gen && (has_big_number(params) ||
                         (cJSON_IsString(gen) && strcmp(gen->valuestring, "heightfield") == 0 &&
                          !cJSON_GetObjectItemCaseSensitive(params, "resolution"))));
    }
    cJSON_Delete(root);
    return costly;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (too_costly(data, size))
        return 0;
    const char *path = fuzz_write("scene.json", data, size);
    scene s;
    vx_err e;
    if (scene_load(path, &s, &e) == 0)
        scene_free(&s);
    return 0;
}
