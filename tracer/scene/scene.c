/* Scene file loading: JSON (cJSON) → scene. Every error names the scene file and the field. */
#include "scene.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "animation.h"
#include "generator.h"
#include "instancing.h"
#include "scene_tris.h"
#include "json_util.h"
#include "mesh_load.h"
#include "mesh_subdivide.h"
#include "readfile.h"
#include "xform.h"

#define MAX_IMAGE_SIDE 16384
#define MAX_IMAGE_PIXELS (64 * 1024 * 1024)

static const char *const effect_names[] = {"shadows", "specular", "dof", "textures"};

unsigned effect_from_name(const char *name)
{
    for (unsigned i = 0; i < sizeof effect_names / sizeof *effect_names; i++)
        if (strcmp(name, effect_names[i]) == 0)
            return 1u << i;
    return 0;
}

const char *effect_name(unsigned effect)
{
    for (unsigned i = 0; i < sizeof effect_names / sizeof *effect_names; i++)
        if (effect == (1u << i))
            return effect_names[i];
    return "?";
}

static char *read_file(const char *path, vx_err *e)
{
    size_t size;
    /* Scene files are small; 64 MiB is far beyond any hand-written or generated one. */
    char *text = readfile_all(path, "scene file", 64u << 20, &size, e);
    /* The parser reads up to the first NUL byte: whatever follows one would go unread. */
    if (text && strlen(text) != size) {
        vx_fail(e, "%s: byte %zu is a NUL: expected JSON text", path, strlen(text));
        free(text);
        return NULL;
    }
    return text;
}

/* Resolves a path relative to the scene file's directory (absolute paths stay as they are). */
static void resolve_path(const char *scene_path, const char *rel, char *out, size_t out_size)
{
    const char *slash = strrchr(scene_path, '/');
    if (rel[0] == '/' || !slash)
        snprintf(out, out_size, "%s", rel);
    else
        snprintf(out, out_size, "%.*s/%s", (int)(slash - scene_path), scene_path, rel);
}

/* Records a file the load read (scene.inputs). where is "SCENE: objects[0]" or "SCENE: materials.x";
 * the field keeps the part after the scene's path. */
static int note_input(scene *s, const char *where, const char *kind, const char *path, vx_err *e)
{
    size_t n = strlen(s->path);
    if (strncmp(where, s->path, n) == 0 && strncmp(where + n, ": ", 2) == 0)
        where += n + 2;
    char field[600];
    snprintf(field, sizeof field, "%s.%s", where, kind);
    char **p = realloc(s->inputs, sizeof *p * (size_t)(s->input_count + 1));
    if (p)
        s->inputs = p;
    char **f = p ? realloc(s->input_fields, sizeof *f * (size_t)(s->input_count + 1)) : NULL;
    if (f)
        s->input_fields = f;
    char *path_copy = f ? strdup(path) : NULL, *field_copy = path_copy ? strdup(field) : NULL;
    if (!field_copy) {
        free(path_copy);
        return vx_fail(e, "%s: out of memory", where);
    }
    s->inputs[s->input_count] = path_copy;
    s->input_fields[s->input_count++] = field_copy;
    return 0;
}

static int parse_color(const cJSON *obj, const char *field, const char *where, vec3 *out, vx_err *e)
{
    if (json_vec3(obj, field, where, out, e))
        return -1;
    if (out->x < 0 || out->y < 0 || out->z < 0)
        return vx_fail(e, "%s%s%s: expected non-negative values", where, json_sep(where), field);
    return 0;
}

/* A diffuse albedo: every component in [0, 1]. Above 1 a surface would reflect more light than it
 * receives, and the models that store colours in 8 bits (heitz-neyret, vmesh, vicini) cannot hold
 * it: they would show 1 where the truth shows the value given. */
static int parse_albedo(const cJSON *obj, const char *field, const char *where, vec3 *out, vx_err *e)
{
    if (json_vec3(obj, field, where, out, e))
        return -1;
    if (!(out->x >= 0 && out->x <= 1 && out->y >= 0 && out->y <= 1 && out->z >= 0 && out->z <= 1))
        return vx_fail(e, "%s%s%s: expected an albedo: 3 numbers from 0 to 1 (got %g, %g, %g)", where, json_sep(where),
                       field, out->x, out->y, out->z);
    return 0;
}

static int parse_texture(scene *s, const cJSON *tex, const char *where, vx_err *e)
{
    texture t;
    memset(&t, 0, sizeof t);
    char path[4096];
    if (cJSON_IsString(tex)) {
        resolve_path(s->path, tex->valuestring, path, sizeof path);
        if (texture_load_image(&t, path, e))
            return vx_wrap(e, "%s.texture", where);
        if (note_input(s, where, "texture", path, e)) {
            texture_free(&t);
            return -1;
        }
    } else if (cJSON_IsObject(tex) && cJSON_GetObjectItemCaseSensitive(tex, "checker")) {
        const cJSON *c = cJSON_GetObjectItemCaseSensitive(tex, "checker");
        char w2[512];
        snprintf(w2, sizeof w2, "%s.texture.checker", where);
        static const char *const known[] = {"scale", "color2", NULL};
        double scale = 8;
        t.kind = TEXTURE_CHECKER;
        t.color2 = v3(0.25f, 0.25f, 0.25f);
        if (!cJSON_IsObject(c))
            return vx_fail(e, "%s: expected an object", w2);
        if (json_only_fields(c, w2, known, e) || json_number_in(c, "scale", w2, 1e-6, 1e6, &scale, e) ||
            parse_albedo(c, "color2", w2, &t.color2, e))
            return -1;
        t.scale = (float)scale;
    } else {
        return vx_fail(e, "%s.texture: expected an image path or {\"checker\": {...}}", where);
    }
    s->textures = realloc(s->textures, sizeof(texture) * (size_t)(s->texture_count + 1));
    s->textures[s->texture_count] = t;
    return s->texture_count++;
}

static int parse_materials(scene *s, const cJSON *root, vx_err *e)
{
    const cJSON *mats = cJSON_GetObjectItemCaseSensitive(root, "materials");
    if (!mats)
        return vx_fail(e, "%s: missing field \"materials\" (an object of named materials)", s->path);
    if (!cJSON_IsObject(mats) || cJSON_GetArraySize(mats) == 0)
        return vx_fail(e, "%s: materials: expected a non-empty object of named materials", s->path);
    int n = cJSON_GetArraySize(mats);
    s->materials = calloc((size_t)n, sizeof(material));
    s->material_names = calloc((size_t)n, sizeof(char *));
    s->shadow_sigma = calloc((size_t)n, sizeof(float));
    if (!s->materials || !s->material_names || !s->shadow_sigma)
        return vx_fail(e, "%s: materials: out of memory", s->path);
    const cJSON *m;
    cJSON_ArrayForEach(m, mats)
    {
        char where[512];
        snprintf(where, sizeof where, "%s: materials.%s", s->path, m->string);
        static const char *const known[] = {"color",   "specular",     "roughness", "double_sided",
                                            "texture", "shadow_sigma", NULL};
        if (!cJSON_IsObject(m))
            return vx_fail(e, "%s: expected an object", where);
        material mat = {v3(0.8f, 0.8f, 0.8f), 0.04f, 0.3f, 0, -1};
        double spec = mat.specular, rough = mat.roughness;
        if (json_only_fields(m, where, known, e) || parse_albedo(m, "color", where, &mat.color, e) ||
            json_number_in(m, "specular", where, 0, 1, &spec, e) ||
            json_number_in(m, "roughness", where, 1e-3, 2, &rough, e) ||
            json_bool(m, "double_sided", where, &mat.double_sided, e))
            return -1;
        /* Slicemap shadows only (Eisemann & Decoret §3.1): the fraction of light one light-grid cell
         * of this material absorbs (foliage); absent, the material is opaque. Kept out of the
         * material (and so out of the scene's identity, which .vox files are checked against): it
         * changes no bake. */
        double sigma = 0.0;
        if (json_number_in(m, "shadow_sigma", where, 1e-6, 1.0, &sigma, e))
            return -1;
        s->shadow_sigma[s->material_count] = (float)sigma;
        mat.specular = (float)spec;
        mat.roughness = (float)rough;
        const cJSON *tex = cJSON_GetObjectItemCaseSensitive(m, "texture");
        if (tex && (mat.texture = parse_texture(s, tex, where, e)) < 0)
            return -1;
        s->materials[s->material_count] = mat;
        s->material_names[s->material_count++] = strdup(m->string);
    }
    return 0;
}

/* Appends a material named `name` (copied) and returns its index, or -1 when out of memory. */
static int add_material(scene *s, material mat, float shadow_sigma, const char *name, vx_err *e)
{
    material *m = realloc(s->materials, sizeof *m * (size_t)(s->material_count + 1));
    if (m)
        s->materials = m;
    float *sg = realloc(s->shadow_sigma, sizeof *sg * (size_t)(s->material_count + 1));
    if (sg)
        s->shadow_sigma = sg;
    char **n = realloc(s->material_names, sizeof *n * (size_t)(s->material_count + 1));
    if (n)
        s->material_names = n;
    char *copy = strdup(name);
    if (!m || !sg || !n || !copy) {
        free(copy);
        return vx_fail(e, "out of memory for material %s", name);
    }
    s->shadow_sigma[s->material_count] = shadow_sigma;
    s->materials[s->material_count] = mat;
    s->material_names[s->material_count] = copy;
    return s->material_count++;
}

/* A glTF file's own materials (mesh_load_gltf_materials): each is the object's scene material
 * (specular, roughness, sidedness) with the glTF's base colour factor as its colour and its
 * baseColorTexture, named "objects[i]#<glTF material>". */
typedef struct {
    scene *s;
    int base;          /* the object's scene material */
    const char *where; /* "file: objects[i]" */
} gltf_materials;

/* A file a glTF names (its external buffers and images): an input too (note_input), which no output
 * may overwrite. */
typedef struct {
    scene *s;
    const char *where; /* "file: objects[i]" */
    vx_err *e;
} gltf_files;

static int note_gltf_file(void *p, const char *file)
{
    gltf_files *g = p;
    return note_input(g->s, g->where, "gltf (a file it names)", file, g->e);
}

static int make_gltf_material(void *p, int index, const gltf_material_desc *d, uint32_t *out, vx_err *e)
{
    gltf_materials *g = p;
    scene *s = g->s;
    material mat = s->materials[g->base];
    mat.color = v3((float)d->base_color[0], (float)d->base_color[1], (float)d->base_color[2]);
    mat.texture = -1;
    if (d->texels) {
        texture t;
        if (texture_from_srgb8(&t, d->width, d->height, d->components, d->texels, e))
            return -1;
        texture *tx = realloc(s->textures, sizeof(texture) * (size_t)(s->texture_count + 1));
        if (!tx) {
            texture_free(&t);
            return vx_fail(e, "out of memory for a texture");
        }
        s->textures = tx;
        s->textures[s->texture_count] = t;
        mat.texture = s->texture_count++;
    }
    const char *at = strrchr(g->where, ':');
    char name[512];
    if (d->name && *d->name)
        snprintf(name, sizeof name, "%s#%s", at ? at + 2 : g->where, d->name);
    else
        snprintf(name, sizeof name, "%s#material %d", at ? at + 2 : g->where, index);
    int i = add_material(s, mat, s->shadow_sigma[g->base], name, e);
    if (i < 0)
        return -1;
    *out = (uint32_t)i;
    return 0;
}

static int find_material(const scene *s, const char *name, const char *where, vx_err *e)
{
    for (int i = 0; i < s->material_count; i++)
        if (strcmp(s->material_names[i], name) == 0)
            return i;
    return vx_fail(e, "%s: unknown material \"%s\" (not in \"materials\")", where, name);
}

static int parse_effects(scene *s, const cJSON *root, vx_err *e)
{
    const cJSON *fx = cJSON_GetObjectItemCaseSensitive(root, "effects");
    if (!fx)
        return 0;
    if (!cJSON_IsArray(fx))
        return vx_fail(e, "%s: effects: expected an array of effect names", s->path);
    int i = 0;
    const cJSON *f;
    cJSON_ArrayForEach(f, fx)
    {
        unsigned bit = cJSON_IsString(f) ? effect_from_name(f->valuestring) : 0;
        if (!bit)
            return vx_fail(e, "%s: effects[%d]: unknown effect %s (expected one of shadows, specular, dof, textures)",
                           s->path, i, cJSON_IsString(f) ? f->valuestring : "(not a string)");
        /* Named twice is a slip (of a variant's list, say), refused as a key given twice is. */
        if (s->effects & bit)
            return vx_fail(e, "%s: effects[%d]: %s is listed twice", s->path, i, f->valuestring);
        s->effects |= bit;
        i++;
    }
    return 0;
}

/* "shadows": {"method": "march" | "slicemap" | "slicemap-model" | "voxel", "resolution": N}: how the declared
 * shadows effect is computed (voxlab's --shadows and --shadow-res override it). Only with the
 * effect: a method for shadows the scene does not have is a contradiction, refused. */
static int parse_shadows(scene *s, const cJSON *root, vx_err *e)
{
    const cJSON *sh = cJSON_GetObjectItemCaseSensitive(root, "shadows");
    if (!sh)
        return 0;
    char where[512];
    snprintf(where, sizeof where, "%s: shadows", s->path);
    static const char *const known[] = {"method", "resolution", NULL};
    if (!cJSON_IsObject(sh))
        return vx_fail(e, "%s: expected an object {\"method\": ..., \"resolution\": N}", where);
    if (!(s->effects & EFFECT_SHADOWS))
        return vx_fail(e, "%s: the scene does not declare the \"shadows\" effect (add it to \"effects\")", where);
    const char *method = NULL;
    if (json_only_fields(sh, where, known, e) || json_string(sh, "method", where, &method, e) ||
        json_int_in(sh, "resolution", where, 1, SCENE_MAX_SHADOW_RES, &s->shadow_res, e))
        return -1;
    if (method) {
        /* In the order of SHADOW_* (shadow_maps_core.h). */
        static const char *const names[] = {"march", "slicemap", "slicemap-model", "voxel"};
        s->shadow_method = -1;
        for (int i = 0; i < (int)(sizeof names / sizeof *names); i++)
            if (strcmp(method, names[i]) == 0)
                s->shadow_method = i;
        if (s->shadow_method < 0)
            return vx_fail(e, "%s.method: unknown shadow method \"%s\" (expected one of march, slicemap, "
                              "slicemap-model, voxel)",
                           where, method);
    }
    return 0;
}

/* The top level's "size"; `path` is the scene file's. */
static int parse_size(const cJSON *obj, const char *path, int *w, int *h, vx_err *e)
{
    const cJSON *size = cJSON_GetObjectItemCaseSensitive(obj, "size");
    if (!size)
        return 0;
    if (!cJSON_IsArray(size) || cJSON_GetArraySize(size) != 2 || !cJSON_IsNumber(cJSON_GetArrayItem(size, 0)) ||
        !cJSON_IsNumber(cJSON_GetArrayItem(size, 1)))
        return vx_fail(e, "%s: size: expected [width, height]", path);
    double dw = cJSON_GetArrayItem(size, 0)->valuedouble, dh = cJSON_GetArrayItem(size, 1)->valuedouble;
    if (dw != floor(dw) || dh != floor(dh) || dw < 1 || dh < 1 || dw > MAX_IMAGE_SIDE || dh > MAX_IMAGE_SIDE ||
        dw * dh > MAX_IMAGE_PIXELS)
        return vx_fail(e, "%s: size: %gx%g is not a valid image size (integers from 1 to %d, at most %d pixels)", path,
                       dw, dh, MAX_IMAGE_SIDE, MAX_IMAGE_PIXELS);
    *w = (int)dw;
    *h = (int)dh;
    return 0;
}

int scene_parse_size_string(const char *text, int *w, int *h, vx_err *e)
{
    char extra;
    long lw, lh;
    if (sscanf(text, "%ldx%ld%c", &lw, &lh, &extra) != 2 || lw < 1 || lh < 1 || lw > MAX_IMAGE_SIDE ||
        lh > MAX_IMAGE_SIDE || lw * lh > MAX_IMAGE_PIXELS)
        return vx_fail(e, "--size %s: expected WxH with integers from 1 to %d (at most %d pixels)", text,
                       MAX_IMAGE_SIDE, MAX_IMAGE_PIXELS);
    *w = (int)lw;
    *h = (int)lh;
    return 0;
}

static int parse_camera(scene *s, const cJSON *root, vx_err *e)
{
    const cJSON *cam = cJSON_GetObjectItemCaseSensitive(root, "camera");
    char where[512];
    snprintf(where, sizeof where, "%s: camera", s->path);
    if (!cJSON_IsObject(cam))
        return vx_fail(e, "%s: missing or invalid field \"camera\" (an object)", s->path);
    static const char *const known[] = {"position", "orbit", "look_at", "up", "fov_deg", "aperture",
                                        "focus_distance", NULL};
    vec3 pos = v3(0, 0, 5), at = v3(0, 0, 0), up = v3(0, 1, 0);
    double fov = 40, aperture = 0, focus = -1;
    if (json_only_fields(cam, where, known, e) || json_vec3(cam, "look_at", where, &at, e) ||
        json_vec3(cam, "up", where, &up, e) || json_number_in(cam, "fov_deg", where, 0.01, 179, &fov, e) ||
        json_number_in(cam, "aperture", where, 0, 1e6, &aperture, e) ||
        json_number_in(cam, "focus_distance", where, 1e-6, 1e9, &focus, e))
        return -1;
    const cJSON *orbit = cJSON_GetObjectItemCaseSensitive(cam, "orbit");
    /* Either places the camera: with both, one would be dropped without a word. */
    if (orbit && cJSON_GetObjectItemCaseSensitive(cam, "position"))
        return vx_fail(e, "%s: has both \"position\" and \"orbit\": expected one of them (orbit places the camera "
                          "around look_at)",
                       where);
    if (orbit) {
        char w2[600];
        snprintf(w2, sizeof w2, "%s.orbit", where);
        static const char *const okeys[] = {"distance", "elevation_deg", "azimuth_deg", NULL};
        double dist = 5, elev = 30, azim = 0;
        if (!cJSON_IsObject(orbit))
            return vx_fail(e, "%s: expected an object", w2);
        if (json_only_fields(orbit, w2, okeys, e) || json_number_in(orbit, "distance", w2, 1e-6, 1e9, &dist, e) ||
            json_number_in(orbit, "elevation_deg", w2, -90, 90, &elev, e) ||
            json_number(orbit, "azimuth_deg", w2, &azim, e))
            return -1;
        double el = elev * M_PI / 180, az = azim * M_PI / 180;
        pos = v3_add(at, v3((float)(dist * cos(el) * sin(az)), (float)(dist * sin(el)), (float)(dist * cos(el) * cos(az))));
    } else if (!cJSON_GetObjectItemCaseSensitive(cam, "position")) {
        return vx_fail(e, "%s: needs \"position\" or \"orbit\"", where);
    } else if (json_vec3(cam, "position", where, &pos, e)) {
        return -1;
    }
    camera *c = &s->camera;
    c->position = pos;
    /* Coordinates this large overflow the direction's length (2.9e38 once read as "up parallel to
     * the viewing direction"): say which field is out of range instead. */
    const float big = 1e18f;
    const vec3 ends[2] = {pos, at};
    for (int k = 0; k < 2; k++)
        if (!(fabsf(ends[k].x) <= big && fabsf(ends[k].y) <= big && fabsf(ends[k].z) <= big))
            return vx_fail(e, "%s.%s: (%g, %g, %g) is out of range (expected coordinates within +-1e18)", where,
                           k ? "look_at" : (orbit ? "orbit" : "position"), (double)ends[k].x, (double)ends[k].y,
                           (double)ends[k].z);
    vec3 fwd = v3_sub(at, pos);
    if (v3_length(fwd) < 1e-12f)
        return vx_fail(e, "%s: look_at equals the position", where);
    c->forward = v3_normalize(fwd);
    vec3 right = v3_cross(c->forward, up);
    if (v3_length(right) < 1e-6f)
        return vx_fail(e, "%s.up: parallel to the viewing direction", where);
    c->right = v3_normalize(right);
    c->up = v3_cross(c->right, c->forward);
    c->tan_half_fov_y = (float)tan(fov * M_PI / 360);
    c->aperture_radius = (float)aperture;
    c->focus_distance = focus > 0 ? (float)focus : v3_length(fwd);
    return 0;
}

/* Refuses a light's field that only the other type of light reads (a directional light's
 * "intensity" would be dropped without a word, its "irradiance" being the one that counts). */
static int light_fields_of_type(const cJSON *l, const char *where, const char *type, const char *const *foreign,
                                const char *expected, const char *other, vx_err *e)
{
    for (const char *const *f = foreign; *f; f++)
        if (cJSON_GetObjectItemCaseSensitive(l, *f))
            return vx_fail(e, "%s: a %s light has \"%s\": expected %s (\"%s\" is a %s light's)", where, type, *f,
                           expected, *f, other);
    return 0;
}

static int parse_lights(scene *s, const cJSON *root, vx_err *e)
{
    const cJSON *lights = cJSON_GetObjectItemCaseSensitive(root, "lights");
    if (!cJSON_IsArray(lights) || cJSON_GetArraySize(lights) == 0)
        return vx_fail(e, "%s: lights: expected a non-empty array of lights", s->path);
    if (cJSON_GetArraySize(lights) > LIGHT_MAX_COUNT)
        return vx_fail(e, "%s: lights: %d lights; expected at most %d (the tracers' per-voxel light arrays)", s->path,
                       cJSON_GetArraySize(lights), LIGHT_MAX_COUNT);
    s->lights = calloc((size_t)cJSON_GetArraySize(lights), sizeof(light));
    if (!s->lights)
        return vx_fail(e, "%s: lights: out of memory", s->path);
    s->light_count = cJSON_GetArraySize(lights);
    int i = 0;
    const cJSON *l;
    cJSON_ArrayForEach(l, lights)
    {
        char where[512];
        snprintf(where, sizeof where, "%s: lights[%d]", s->path, i);
        const char *type = NULL;
        light *L = &s->lights[i++];
        static const char *const known[] = {"type", "direction", "position", "irradiance", "intensity", NULL};
        if (!cJSON_IsObject(l))
            return vx_fail(e, "%s: expected an object", where);
        if (json_only_fields(l, where, known, e) || json_string(l, "type", where, &type, e))
            return -1;
        static const char *const point_only[] = {"position", "intensity", NULL};
        static const char *const directional_only[] = {"direction", "irradiance", NULL};
        if (type && strcmp(type, "directional") == 0) {
            if (light_fields_of_type(l, where, type, point_only, "\"direction\" and \"irradiance\"", "point", e))
                return -1;
            L->type = LIGHT_DIRECTIONAL;
            L->direction = v3(0, 1, 0);
            L->radiance = v3(3, 3, 3);
            if (json_vec3(l, "direction", where, &L->direction, e) ||
                parse_color(l, "irradiance", where, &L->radiance, e))
                return -1;
            if (v3_length(L->direction) < 1e-12f)
                return vx_fail(e, "%s.direction: must not be zero", where);
            L->direction = v3_normalize(L->direction);
        } else if (type && strcmp(type, "point") == 0) {
            if (light_fields_of_type(l, where, type, directional_only, "\"position\" and \"intensity\"", "directional",
                                     e))
                return -1;
            L->type = LIGHT_POINT;
            L->radiance = v3(10, 10, 10);
            if (!cJSON_GetObjectItemCaseSensitive(l, "position"))
                return vx_fail(e, "%s: a point light needs \"position\"", where);
            if (json_vec3(l, "position", where, &L->position, e) ||
                parse_color(l, "intensity", where, &L->radiance, e))
                return -1;
        } else {
            return vx_fail(e, "%s.type: expected \"directional\" or \"point\"", where);
        }
    }
    return 0;
}

/* The object's "transform" (xform.h: scale, rotate, translate; normals by the inverse transpose). */
static int apply_transform(mesh *m, size_t v0, size_t t0, const cJSON *xf, const char *where, vx_err *e)
{
    if (!xf)
        return 0;
    char w2[600];
    snprintf(w2, sizeof w2, "%s.transform", where);
    xform x;
    if (xform_parse(xf, w2, &x, e))
        return -1;
    xform_apply(m, v0, t0, &x);
    return 0;
}

static int parse_generator_object(scene *s, const cJSON *o, const char *where, vx_err *e)
{
    const char *name = NULL;
    uint64_t seed = 1;
    if (json_string(o, "generator", where, &name, e) || json_u64(o, "seed", where, &seed, e))
        return -1;
    const scene_generator *g = generator_find(name);
    if (!g) {
        char list[512] = "";
        for (const scene_generator *const *it = generator_all(); *it; it++)
            snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", list[0] ? ", " : "", (*it)->name);
        return vx_fail(e, "%s.generator: unknown generator \"%s\" (known: %s)", where, name, list);
    }
    uint32_t slots[16];
    const cJSON *mats = cJSON_GetObjectItemCaseSensitive(o, "materials");
    const char *fallback = NULL;
    if (json_string(o, "material", where, &fallback, e))
        return -1;
    if (mats && !cJSON_IsObject(mats))
        return vx_fail(e, "%s.materials: expected an object mapping slots to material names", where);
    int nslots = 0;
    for (; g->slots[nslots] && nslots < 16; nslots++) {
        const char *mat = fallback;
        char w2[600];
        snprintf(w2, sizeof w2, "%s.materials", where);
        if (mats && json_string(mats, g->slots[nslots], w2, &mat, e))
            return -1;
        if (!mat)
            return vx_fail(e, "%s.materials.%s: no material for generator slot \"%s\" (and no \"material\")", where,
                           g->slots[nslots], g->slots[nslots]);
        int idx = find_material(s, mat, where, e);
        if (idx < 0)
            return -1;
        slots[nslots] = (uint32_t)idx;
    }
    if (mats && json_only_fields(mats, where, g->slots, e))
        return -1;
    const cJSON *params = cJSON_GetObjectItemCaseSensitive(o, "params");
    char w3[600];
    snprintf(w3, sizeof w3, "%s.params", where);
    if (params && !cJSON_IsObject(params))
        return vx_fail(e, "%s: expected an object", w3);
    return g->generate(params, w3, seed, slots, &s->mesh, e);
}

/* A texture the render will not use is said, not silently dropped: the scene does not declare the
 * "textures" effect, or the object's mesh has no texture coordinates (every uv 0). The object's
 * triangles are those from t0 on, its vertices those from v0 on. */
static void warn_unused_texture(const scene *s, size_t v0, size_t t0, const char *where)
{
    int textured = 0;
    for (size_t t = t0; t < s->mesh.triangle_count && !textured; t++)
        textured = s->materials[s->mesh.materials[t]].texture >= 0;
    if (!textured)
        return;
    if (!(s->effects & EFFECT_TEXTURES)) {
        fprintf(stderr, "voxlab: warning: %s: its material has a texture, but the scene does not declare the "
                        "\"textures\" effect: the texture is not used\n",
                where);
        return;
    }
    for (size_t v = v0; v < s->mesh.vertex_count; v++)
        if (s->mesh.uvs[2 * v] != 0.0f || s->mesh.uvs[2 * v + 1] != 0.0f)
            return;
    fprintf(stderr, "voxlab: warning: %s: its material has a texture, but the mesh has no texture coordinates: the "
                    "texture's corner colour is used everywhere\n",
            where);
}

/* An object's one source of triangles, and no field that only another kind of source reads: with
 * "ply" and "obj" both given, the obj was never even opened; a ply's "seed" would be ignored. *kind
 * is the source ("generator", "ply", "obj" or "gltf"). */
static int object_source(const cJSON *o, const char *where, const char **kind, vx_err *e)
{
    static const char *const sources[] = {"generator", "ply", "obj", "gltf"};
    *kind = NULL;
    for (int k = 0; k < 4; k++) {
        if (!cJSON_GetObjectItemCaseSensitive(o, sources[k]))
            continue;
        if (*kind)
            return vx_fail(e, "%s: has both \"%s\" and \"%s\": expected one mesh source", where, *kind, sources[k]);
        *kind = sources[k];
    }
    if (!*kind)
        return vx_fail(e, "%s: expected one of \"generator\", \"ply\", \"obj\" or \"gltf\"", where);
    static const char *const generator_only[] = {"seed", "params", "materials", NULL};
    for (const char *const *f = generator_only; strcmp(*kind, "generator") != 0 && *f; f++)
        if (cJSON_GetObjectItemCaseSensitive(o, *f))
            return vx_fail(e, "%s: a %s object has \"%s\": expected it only with \"generator\"", where, *kind, *f);
    if (strcmp(*kind, "gltf") != 0 && cJSON_GetObjectItemCaseSensitive(o, "uris_outside_folder"))
        return vx_fail(e, "%s: a %s object has \"uris_outside_folder\": expected it only with \"gltf\" (a glTF's "
                          "external buffers)",
                       where, *kind);
    return 0;
}

static int parse_objects(scene *s, const cJSON *root, vx_err *e)
{
    const cJSON *objs = cJSON_GetObjectItemCaseSensitive(root, "objects");
    if (!cJSON_IsArray(objs) || cJSON_GetArraySize(objs) == 0)
        return vx_fail(e, "%s: objects: expected a non-empty array of objects", s->path);
    int i = 0;
    const cJSON *o;
    cJSON_ArrayForEach(o, objs)
    {
        char where[512];
        snprintf(where, sizeof where, "%s: objects[%d]", s->path, i++);
        static const char *const known[] = {"generator", "seed", "params", "materials", "material",
                                            "ply", "gltf", "obj", "transform", "uris_outside_folder", "animation",
                                            "name", "instances", "scatter", "subdivide", NULL};
        if (!cJSON_IsObject(o))
            return vx_fail(e, "%s: expected an object", where);
        const char *kind;
        if (json_only_fields(o, where, known, e) || object_source(o, where, &kind, e))
            return -1;
        size_t v0 = s->mesh.vertex_count, t0 = s->mesh.triangle_count;
        const char *file = NULL, *matname = NULL;
        int creased = 0; /* a PLY or OBJ: normals the file lacks get creases (below) */
        int levels;      /* "subdivide", read first: a glTF's loader shares vertices for it */
        s->mesh.normals_smoothed = 0;
        if (mesh_subdivide_levels(o, where, &levels, e))
            return -1;
        if (strcmp(kind, "generator") == 0) {
            if (parse_generator_object(s, o, where, e))
                return -1;
        } else {
            int is_ply = strcmp(kind, "ply") == 0, is_obj = strcmp(kind, "obj") == 0;
            creased = is_ply || is_obj;
            if (json_string(o, kind, where, &file, e) || json_string(o, "material", where, &matname, e))
                return -1;
            /* A glTF brings its own materials: the scene's is optional there (white, default lobe). */
            int mat;
            if (!matname && !is_ply && !is_obj) {
                material white = {v3(1.0f, 1.0f, 1.0f), 0.04f, 0.3f, 0, -1};
                const char *at = strrchr(where, ':');
                char name[512];
                snprintf(name, sizeof name, "%s#default", at ? at + 2 : where);
                mat = add_material(s, white, 0.0f, name, e);
            } else if (!matname) {
                return vx_fail(e, "%s: missing field \"material\"", where);
            } else {
                mat = find_material(s, matname, where, e);
            }
            if (mat < 0)
                return -1;
            int anywhere = 0; /* a glTF's external buffers only from its own folder unless allowed */
            if (cJSON_GetObjectItemCaseSensitive(o, "uris_outside_folder") &&
                json_bool(o, "uris_outside_folder", where, &anywhere, e))
                return -1;
            char path[4096];
            resolve_path(s->path, file, path, sizeof path);
            gltf_materials own = {s, mat, where};
            gltf_files named = {s, where, e};
            int rc = is_ply   ? mesh_load_ply(path, &s->mesh, (uint32_t)mat, e)
                     : is_obj ? mesh_load_obj(path, &s->mesh, (uint32_t)mat, e)
                              : mesh_load_gltf_files(path, &s->mesh, (uint32_t)mat, anywhere, levels > 0,
                                                     make_gltf_material, &own, note_gltf_file, &named, e);
            if (rc)
                return vx_wrap(e, "%s.%s", where, kind);
            if (note_input(s, where, kind, path, e))
                return -1;
            warn_unused_texture(s, v0, t0, where);
        }
        /* "subdivide": k Loop levels, on the object as loaded, before its placement. */
        if (mesh_subdivide_object(&s->mesh, v0, t0, levels, where, e))
            return -1;
        /* A PLY or OBJ without normals (or subdivided, whose normals are recomputed): smooth normals
         * with creases (mesh_crease_normals), after the subdivision, whose connectivity is by vertex
         * index and would tear where the creases split the vertices. (A glTF's normals are given or
         * computed per primitive by its loader: flat, as its spec asks, or smooth before a
         * subdivision, which recomputes them.) */
        if (creased && s->mesh.normals_smoothed)
            mesh_crease_normals(&s->mesh, v0, t0, MESH_CREASE_DEG);
        if (apply_transform(&s->mesh, v0, t0, cJSON_GetObjectItemCaseSensitive(o, "transform"), where, e) ||
            inst_parse_object(s, o, where, v0, t0, e) || anim_parse_object(s, o, where, i - 1, v0, e))
            return -1;
        for (size_t v = v0; v < s->mesh.vertex_count; v++)
            for (int k = 0; k < 3; k++)
                if (!isfinite(s->mesh.positions[3 * v + (size_t)k]))
                    return vx_fail(e, "%s: vertex %zu has a non-finite coordinate", where, v - v0);
    }
    return 0;
}

/* Drops the mesh's zero-area triangles (they have no surface to shade or voxelise) and counts
 * them. Prototypes keep theirs: a copy is numbered as its prototype (scene_tris.h), and every
 * consumer skips a triangle without area (the voxeliser's setup, the ray tests' determinant). */
static void drop_degenerate(scene *s)
{
    mesh *m = &s->mesh;
    size_t kept = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        const uint32_t *tri = &m->indices[3 * t];
        vec3 a = mesh_position(m, tri[0]), b = mesh_position(m, tri[1]), c = mesh_position(m, tri[2]);
        vec3 n = v3_cross(v3_sub(b, a), v3_sub(c, a));
        if (!(v3_dot(n, n) > 0.0f)) {
            s->degenerate_triangles++;
            continue;
        }
        memmove(&m->indices[3 * kept], tri, 3 * sizeof(uint32_t));
        m->materials[kept++] = m->materials[t];
    }
    m->triangle_count = kept;
}

static uint64_t hash_bytes(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ULL; /* FNV-1a */
    return h;
}

static uint64_t hash_mesh(uint64_t h, const mesh *m)
{
    h = hash_bytes(h, m->positions, m->vertex_count * 3 * sizeof(float));
    h = hash_bytes(h, m->normals, m->vertex_count * 3 * sizeof(float));
    h = hash_bytes(h, m->colors, m->vertex_count * 3 * sizeof(float));
    h = hash_bytes(h, m->uvs, m->vertex_count * 2 * sizeof(float));
    h = hash_bytes(h, m->indices, m->triangle_count * 3 * sizeof(uint32_t));
    return hash_bytes(h, m->materials, m->triangle_count * sizeof(uint32_t));
}

/* The textures' part of the identity: a material's `texture` is only an index, so without this a
 * .vox baked before a texture's texels or a checker's colour changed would still be accepted. Field by
 * field (the struct has padding). Hashed once per load: texels do not move with the frames. */
static uint64_t hash_textures(uint64_t h, const scene *s)
{
    for (int i = 0; i < s->texture_count; i++) {
        const texture *t = &s->textures[i];
        h = hash_bytes(h, &t->kind, sizeof t->kind);
        h = hash_bytes(h, &t->width, sizeof t->width);
        h = hash_bytes(h, &t->height, sizeof t->height);
        h = hash_bytes(h, &t->scale, sizeof t->scale);
        float c2[3] = {t->color2.x, t->color2.y, t->color2.z};
        h = hash_bytes(h, c2, sizeof c2);
        if (t->rgb)
            h = hash_bytes(h, t->rgb, (size_t)t->width * (size_t)t->height * 3 * sizeof(float));
    }
    return h;
}

static void compute_bounds_and_identity(scene *s)
{
    mesh *m = &s->mesh;
    double lo[3], hi[3];
    scene_triangle_bounds(s, lo, hi);
    s->bounds_lo = v3((float)lo[0], (float)lo[1], (float)lo[2]);
    s->bounds_hi = v3((float)hi[0], (float)hi[1], (float)hi[2]);
    uint64_t h = hash_mesh(0xcbf29ce484222325ULL, m);
    const scene_instancing *in = s->inst;
    for (int q = 0; in && q < in->proto_count; q++) /* the prototypes once, then each placement */
        h = hash_mesh(h, &in->protos[q]);
    for (size_t i = 0; in && i < in->count; i++) {
        h = hash_bytes(h, &in->inst[i].proto, sizeof in->inst[i].proto);
        h = hash_bytes(h, in->inst[i].m, sizeof in->inst[i].m);
    }
    for (int i = 0; i < s->material_count; i++)
        h = hash_bytes(h, &s->materials[i], sizeof(material));
    h = hash_bytes(h, &s->effects, sizeof s->effects);
    /* Scenes without textures keep the identity they had before textures were hashed (their .vox
     * files stay valid). */
    if (s->texture_count > 0) {
        if (!s->texture_identity_done) {
            s->texture_identity = hash_textures(0xcbf29ce484222325ULL, s);
            s->texture_identity_done = 1;
        }
        h = hash_bytes(h, &s->texture_identity, sizeof s->texture_identity);
    }
    s->identity = h;
}

int scene_set_frame(scene *s, int frame, vx_err *e)
{
    int first = s->anim ? s->anim->first : 0, last = s->anim ? s->anim->last : 0;
    if (frame < first || frame > last)
        return vx_fail(e, "%s: frame %d is outside the scene's frames [%d, %d]%s", s->path, frame, first, last,
                       s->anim ? "" : " (the scene has no \"frames\")");
    if (!s->anim || s->anim->count == 0 || s->anim->frame == frame)
        return 0;
    anim_pose_all(s->anim, &s->mesh, frame);
    compute_bounds_and_identity(s);
    return 0;
}

float scene_surface_epsilon(const scene *s)
{
    vec3 ext = v3_sub(s->bounds_hi, s->bounds_lo);
    float size = vx_fmaxf(ext.x, vx_fmaxf(ext.y, ext.z));
    float far = vx_fmaxf(vx_fmaxf(fabsf(s->bounds_lo.x), fabsf(s->bounds_hi.x)),
                         vx_fmaxf(vx_fmaxf(fabsf(s->bounds_lo.y), fabsf(s->bounds_hi.y)),
                                  vx_fmaxf(fabsf(s->bounds_lo.z), fabsf(s->bounds_hi.z))));
    return vx_fmaxf(1e-5f * size, 4e-7f * far);
}

/* Warns when float positions are coarse against the scene's size: a scene far from the origin (or
 * seen from far away) and small. The truth starts its shadow rays the larger of the scene's epsilon
 * and the hit point's rounding off each surface (scene_surface_epsilon, SCENE_HIT_ROUNDING); once
 * that is over 1 % of the scene, contact shadows and thin parts are lost (the audit of issue 15: a
 * scene 1e-3 across placed 1e3 from the origin lost its shadow and showed holes, without a word). */
static void warn_float_precision(const scene *s)
{
    double size = 0.0, far = 0.0, cam = 0.0, dist2 = 0.0;
    for (int a = 0; a < 3; a++) {
        double lo = v3_get(s->bounds_lo, a), hi = v3_get(s->bounds_hi, a), c = v3_get(s->camera.position, a);
        size = fmax(size, hi - lo);
        far = fmax(far, fmax(fabs(lo), fabs(hi)));
        cam = fmax(cam, fabs(c));
        dist2 += (c - 0.5 * (lo + hi)) * (c - 0.5 * (lo + hi));
    }
    double offset = fmax(scene_surface_epsilon(s), SCENE_HIT_ROUNDING * (cam + sqrt(dist2)));
    if (!(offset > 0.01 * size))
        return;
    fprintf(stderr, "voxlab: warning: %s: the scene is %.3g across, %.3g from the origin and seen from %.3g away: "
                    "float positions are coarse against its size there (shadow rays start %.2g of its size off "
                    "its surfaces); place it nearer the origin\n",
            s->path, size, far, sqrt(dist2), offset / size);
}

int scene_load(const char *path, scene *s, vx_err *e)
{
    memset(s, 0, sizeof *s);
    char *text = read_file(path, e);
    if (!text)
        return -1;
    int rc = scene_load_text(text, path, s, e);
    free(text);
    return rc;
}

int scene_load_text(const char *text, const char *path, scene *s, vx_err *e)
{
    memset(s, 0, sizeof *s);
    s->path = strdup(path);
    /* Strictly: text after the document or a key given twice is refused (json_util.h), not read
     * one way here and another way by a script reading the same file. */
    cJSON *root = json_parse_strict(text, path, e);
    if (!root) {
        scene_free(s); /* s->path: every failure leaves nothing allocated */
        return -1;
    }
    int rc = -1;
    static const char *const known[] = {"name",      "size",    "background",  "effects", "camera", "lights",
                                        "materials", "objects", "description", "shadows", "frames", NULL};
    const char *name = NULL;
    s->width = s->height = 256;
    s->background = v3(0, 0, 0);
    if (!cJSON_IsObject(root)) {
        vx_fail(e, "%s: expected a JSON object at the top level", path);
        goto done;
    }
    char top[4200]; /* the top level's fields: "file: background: ..." (json_util.h) */
    snprintf(top, sizeof top, "%s:", path);
    if (json_only_fields(root, path, known, e) || json_string(root, "name", top, &name, e) ||
        parse_size(root, path, &s->width, &s->height, e) || parse_color(root, "background", top, &s->background, e) ||
        parse_effects(s, root, e) || parse_shadows(s, root, e) || parse_camera(s, root, e) || parse_lights(s, root, e) ||
        parse_materials(s, root, e) || parse_objects(s, root, e))
        goto done;
    if (name)
        s->name = strdup(name);
    else {
        const char *base = strrchr(path, '/');
        s->name = strdup(base ? base + 1 : path);
        char *dot = strrchr(s->name, '.');
        if (dot)
            *dot = 0;
    }
    drop_degenerate(s);
    if (s->inst && s->inst->count && inst_compute_bounds(s, e))
        goto done;
    if (scene_triangle_count(s) == 0) {
        vx_fail(e, "%s: objects: the scene has no triangles (after dropping %zu zero-area ones)", path,
                s->degenerate_triangles);
        goto done;
    }
    if (anim_parse_frames(s, root, e))
        goto done;
    compute_bounds_and_identity(s);
    warn_float_precision(s);
    rc = 0;
done:
    cJSON_Delete(root);
    if (rc)
        scene_free(s);
    return rc;
}

void scene_free(scene *s)
{
    mesh_free(&s->mesh);
    for (int i = 0; i < s->material_count; i++)
        free(s->material_names[i]);
    for (int i = 0; i < s->texture_count; i++)
        texture_free(&s->textures[i]);
    free(s->material_names);
    free(s->materials);
    free(s->shadow_sigma);
    free(s->textures);
    free(s->lights);
    free(s->path);
    free(s->name);
    anim_free(s->anim);
    inst_free(s->inst);
    for (int i = 0; i < s->input_count; i++) {
        free(s->inputs[i]);
        free(s->input_fields[i]);
    }
    free(s->inputs);
    free(s->input_fields);
    memset(s, 0, sizeof *s);
}
