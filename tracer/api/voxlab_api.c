/* The Python API's C side (voxlab_api.h): each call does what its CLI command does (cmd_*.c), with
 * the same options, estimates, checks and --stats object, but hands the image and the statistics
 * back instead of writing files. */
#include "voxlab_api.h"

#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "backend.h"
#include "bake.h"
#include "bake_params.h"
#include "cmd_compare.h"
#include "commands.h"
#include "estimate.h"
#include "metrics.h"
#include "render.h"
#include "scene.h"
#include "stats.h"
#include "truth.h"
#include "vox_load.h"
#include "voxfile.h"

/* The CLI's limit: --stats writes the seed as a JSON number, exact up to 2^53. */
#define SEED_MAX (1LL << 53)

struct vxapi_scene {
    scene s;
};

struct vxapi_bake {
    const vx_model *m;
    voxel_grid g;
    void *records;
    bake_options o;
    bake_counts c;
    double grid_seconds;
    uint64_t scene_identity; /* the scene it was baked for: render refuses another */
};

/* Copies a vx_err (or a literal) into the caller's buffer and returns -1. */
static int give_error(const char *msg, char *err, size_t err_size)
{
    if (err && err_size)
        snprintf(err, err_size, "%s", msg);
    return -1;
}

/* The JSON text of j (freed), for *stats; NULL when stats is not asked for. */
static int give_json(cJSON *j, char **stats, char *err, size_t err_size)
{
    if (!stats) {
        cJSON_Delete(j);
        return 0;
    }
    *stats = cJSON_PrintUnformatted(j);
    cJSON_Delete(j);
    return *stats ? 0 : give_error("out of memory for the statistics", err, err_size);
}

/* Hands the image's buffer over to the caller (RGB floats, what render and truth produce). */
static void give_image(image *img, float **pixels, int *width, int *height)
{
    *pixels = img->data;
    *width = img->width;
    *height = img->height;
    img->data = NULL;
}

vxapi_scene *vxapi_scene_load(const char *path, const char *json, const char *base_dir, char *err, size_t err_size)
{
    vxapi_scene *s = calloc(1, sizeof *s);
    vx_err e;
    if (!s) {
        give_error("out of memory for the scene", err, err_size);
        return NULL;
    }
    int rc;
    if (path) {
        rc = scene_load(path, &s->s, &e);
    } else {
        /* Stands for a file in base_dir: messages say "<scene dict>", relative paths resolve there. */
        char label[4096];
        snprintf(label, sizeof label, "%s%s<scene dict>", base_dir ? base_dir : "", base_dir ? "/" : "");
        rc = json ? scene_load_text(json, label, &s->s, &e) : vx_fail(&e, "no scene given (a path or JSON text)");
    }
    if (rc) {
        free(s);
        give_error(e.msg, err, err_size);
        return NULL;
    }
    return s;
}

void vxapi_scene_free(vxapi_scene *s)
{
    if (!s)
        return;
    scene_free(&s->s);
    free(s);
}

void vxapi_scene_size(const vxapi_scene *s, int *width, int *height)
{
    *width = s->s.width;
    *height = s->s.height;
}

/* --size WxH's limits for an explicit size; 0 x 0 keeps the scene's. */
static int image_size(const scene *s, int width, int height, int *w, int *h, vx_err *e)
{
    if (width == 0 && height == 0) {
        *w = s->width;
        *h = s->height;
        return 0;
    }
    char text[64];
    snprintf(text, sizeof text, "%dx%d", width, height);
    return scene_parse_size_string(text, w, h, e);
}

/* The shadow method and resolution as --shadows and --shadow-res check them (truth: no
 * slicemap-model, no voxel). */
static int shadow_args(const char *shadows, int shadow_res, int truth, int *method, char *err, size_t err_size)
{
    *method = -1;
    if (shadows && (*method = shadow_method_from_name(shadows)) < 0)
        return give_error("shadows: expected one of " SHADOW_METHOD_NAMES, err, err_size);
    const char *why = truth ? truth_shadow_method_unavailable(*method) : NULL;
    if (why) {
        char msg[256];
        snprintf(msg, sizeof msg, "shadows: the truth takes march or slicemap (%s)", why);
        return give_error(msg, err, err_size);
    }
    if (shadow_res < 0 || shadow_res > SHADOW_MAX_RES)
        return give_error("shadow_res: expected 0 (the default) to 2048 columns per side", err, err_size);
    return 0;
}

int vxapi_truth(const vxapi_scene *as, int width, int height, int spp, long long seed, int threads, const char *shadows,
                int shadow_res, float **pixels, int *out_width, int *out_height, char **stats, char *err,
                size_t err_size)
{
    const scene *s = &as->s;
    truth_options o = {.spp = spp, .seed = (uint64_t)seed, .threads = threads, .shadow_res = shadow_res};
    vx_err e;
    if (spp < 1 || spp > (1 << 20) || seed < 0 || seed > SEED_MAX || threads < 0)
        return give_error("spp must be 1..1048576, seed 0..2^53, threads non-negative", err, err_size);
    if (shadow_args(shadows, shadow_res, 1, &o.shadow_method, err, err_size))
        return -1;
    if (image_size(s, width, height, &o.width, &o.height, &e))
        return give_error(e.msg, err, err_size);
    vx_estimate est;
    estimate_truth(s, o.width, o.height, o.spp, o.threads, &est);
    rt_scene rt = {0};
    image img = {0};
    truth_counts c;
    int rc = -1;
    if (estimate_check(&est, &e) || rt_build(&rt, s, &e) || truth_render(&rt, &o, &img, &c, &e))
        give_error(e.msg, err, err_size);
    else {
        cJSON *j = stats_truth(s, &o, &c);
        cJSON_AddNumberToObject(j, "bvh_bytes", (double)rt.bvh_bytes); /* as the CLI's --stats */
        cJSON_AddNumberToObject(j, "bvh_seconds", rt.bvh_seconds);
        if ((rc = give_json(j, stats, err, err_size)) == 0)
            give_image(&img, pixels, out_width, out_height);
    }
    image_free(&img);
    rt_free(&rt);
    return rc;
}

vxapi_bake *vxapi_bake_run(const vxapi_scene *as, const char *model, int res, int rays, long long seed, int threads,
                           const char *const *params, int n_params, char **stats, char *err, size_t err_size)
{
    const scene *s = &as->s;
    vx_err e;
    const vx_model *m = model_find(model);
    if (!m) {
        vx_fail(&e, "model %s: unknown model (see `voxlab models`)", model);
        give_error(e.msg, err, err_size);
        return NULL;
    }
    if (res < 1 || res > GRID_MAX_N || rays < 1 || rays > (1 << 20) || seed < 0 || seed > SEED_MAX || threads < 0) {
        vx_fail(&e, "res must be 1..%d, rays 1..1048576, seed 0..2^53, threads non-negative", GRID_MAX_N);
        give_error(e.msg, err, err_size);
        return NULL;
    }
    vxapi_bake *b = calloc(1, sizeof *b);
    if (!b) {
        give_error("out of memory for the bake", err, err_size);
        return NULL;
    }
    b->m = m;
    b->scene_identity = s->identity;
    b->o = (bake_options){.rays = rays, .seed = (uint64_t)seed, .threads = threads, .params_set = 1};
    vx_estimate est;
    if (bake_params_apply(m, params, n_params, &b->o.params, &e) == 0) {
        estimate_voxels(s, m, res, rays, 0, 0, 0, 0, threads, &est);
        if (estimate_check(&est, &e) == 0 &&
            bake_scene(s, m, res, &b->o, &b->g, &b->records, &b->c, &b->grid_seconds, &e) == 0) {
            if (give_json(stats_bake(s, m, &b->o, &b->g, &b->c, b->grid_seconds), stats, err, err_size) == 0)
                return b;
            vxapi_bake_free(b);
            return NULL;
        }
    }
    free(b);
    give_error(e.msg, err, err_size);
    return NULL;
}

vxapi_bake *vxapi_bake_load(const vxapi_scene *as, const char *vox_path, const char *model, char *err,
                            size_t err_size)
{
    vx_err e;
    vxapi_bake *b = calloc(1, sizeof *b);
    if (!b) {
        give_error("out of memory for the bake", err, err_size);
        return NULL;
    }
    voxfile_header h;
    if (vox_load(&as->s, vox_path, model, &b->m, &b->g, &b->records, &h, &b->grid_seconds, &e)) {
        free(b);
        give_error(e.msg, err, err_size);
        return NULL;
    }
    b->scene_identity = as->s.identity;
    b->c.seconds = -1; /* not baked by this run: stats say bake_seconds null, as render --vox does */
    b->o = (bake_options){.rays = (int)h.rays, .seed = h.seed, .params_set = 1};
    if (bake_params_parse(b->m, h.params, &b->o.params, &e)) {
        char why[sizeof e.msg];
        snprintf(why, sizeof why, "%s", e.msg);
        vx_fail(&e, "%s: header field params: %s", vox_path, why);
        vxapi_bake_free(b);
        give_error(e.msg, err, err_size);
        return NULL;
    }
    return b;
}

int vxapi_bake_save(const vxapi_bake *b, const char *vox_path, char *err, size_t err_size)
{
    /* The header names the scene by identity only; a scene object with that identity stands in. */
    scene id = {.identity = b->scene_identity};
    voxfile_header h;
    vx_err e;
    bake_header_fill(&h, &id, b->m, &b->o, &b->g);
    if (voxfile_write(vox_path, &h, b->records, b->g.level[0].coords, &e))
        return give_error(e.msg, err, err_size);
    return 0;
}

void vxapi_bake_free(vxapi_bake *b)
{
    if (!b)
        return;
    free(b->records);
    grid_free(&b->g);
    free(b);
}

int vxapi_render(const vxapi_scene *as, const vxapi_bake *b, int width, int height, int spp, long long seed,
                 int threads, int cache, int shadow_skip, const char *backend_name, const char *shadows,
                 int shadow_res, float **pixels, int *out_width, int *out_height, char **stats, char *err,
                 size_t err_size)
{
    const scene *s = &as->s;
    vx_err e;
    const vx_backend *backend = backend_find(backend_name ? backend_name : "c");
    if (!backend) {
        vx_fail(&e, "backend %s: expected c or opencl", backend_name);
        return give_error(e.msg, err, err_size);
    }
    if (b->scene_identity != s->identity)
        return give_error("the bake was made for another scene (its identity differs)", err, err_size);
    if (spp < 1 || spp > (1 << 16) || seed < 0 || seed > SEED_MAX || threads < 0)
        return give_error("spp must be 1..65536, seed 0..2^53, threads non-negative", err, err_size);
    render_options o;
    render_default_options(&o);
    o.spp = spp;
    o.seed = (uint64_t)seed;
    o.threads = threads;
    o.cache = cache;
    o.shadow_skip = shadow_skip;
    o.shadow_res = shadow_res;
    if (shadow_args(shadows, shadow_res, 0, &o.shadow_method, err, err_size))
        return -1;
    if (image_size(s, width, height, &o.width, &o.height, &e))
        return give_error(e.msg, err, err_size);
    vx_estimate est;
    /* The bake exists already: only the render's own memory is estimated (rays 0, as with --vox). */
    estimate_voxels(s, b->m, b->g.n, 0, o.width, o.height, o.spp, o.cache, o.threads, &est);
    image img = {0};
    render_counts rc;
    backend_counts bc = {0};
    int ret = -1;
    if (estimate_check(&est, &e) || backend->check(b->m, &o, &e) ||
        backend->render(s, &b->g, b->m, b->records, &o, &img, &rc, &bc, &e))
        give_error(e.msg, err, err_size);
    else if ((ret = give_json(stats_render(s, b->m, &b->o, &b->g, &b->c, b->grid_seconds, backend, &o, &rc, &bc),
                              stats, err, err_size)) == 0)
        give_image(&img, pixels, out_width, out_height);
    image_free(&img);
    return ret;
}

int vxapi_image_read(const char *path, float **pixels, int *width, int *height, int *channels, char *err,
                     size_t err_size)
{
    image img;
    vx_err e;
    if (image_read(path, &img, &e))
        return give_error(e.msg, err, err_size);
    *channels = img.channels;
    give_image(&img, pixels, width, height);
    return 0;
}

int vxapi_compare(const float *a, const float *b, int width, int height, int channels, char **json, char *err,
                  size_t err_size)
{
    /* The metrics read the caller's arrays in place: the images only borrow them. */
    image ia = {.width = width, .height = height, .channels = channels, .data = (float *)a};
    image ib = {.width = width, .height = height, .channels = channels, .data = (float *)b};
    image_metrics m;
    vx_err e;
    if (width < 1 || height < 1 || channels < 1 || channels > 4)
        return give_error("images must be at least 1x1 with 1 to 4 channels", err, err_size);
    if (metrics_compare(&ia, &ib, &m, &e))
        return give_error(e.msg, err, err_size);
    if (!(*json = compare_json(&m, width, height, NULL))) /* arrays carry no provenance */
        return give_error("out of memory for the metrics", err, err_size);
    return 0;
}

int vxapi_compare_files(const char *path_a, const char *path_b, char **json, char *err, size_t err_size)
{
    const char *paths[2] = {path_a, path_b};
    image a = {0}, b = {0};
    image_metrics m;
    vx_err e;
    char *prov = NULL;
    int rc = -1;
    if (image_read(path_a, &a, &e) || image_read(path_b, &b, &e))
        give_error(e.msg, err, err_size);
    else if (a.width != b.width || a.height != b.height || a.channels != b.channels) {
        vx_fail(&e, "image sizes differ: %s is %dx%d with %d channels, %s is %dx%d with %d channels", path_a, a.width,
                a.height, a.channels, path_b, b.width, b.height, b.channels);
        give_error(e.msg, err, err_size);
    } else if (metrics_compare(&a, &b, &m, &e)) {
        char why[sizeof e.msg];
        snprintf(why, sizeof why, "%s", e.msg);
        vx_fail(&e, "%s vs %s: %s", path_a, path_b, why);
        give_error(e.msg, err, err_size);
    } else if (compare_provenance_json(paths, &prov, &e)) {
        give_error(e.msg, err, err_size);
    } else if (!(*json = compare_json(&m, a.width, a.height, prov))) {
        give_error("out of memory for the metrics", err, err_size);
    } else {
        rc = 0;
    }
    free(prov);
    image_free(&a);
    image_free(&b);
    return rc;
}

int vxapi_models(char **names)
{
    size_t n = 1;
    for (const vx_model *const *m = model_all(); *m; m++)
        n += strlen((*m)->name) + 1;
    if (!(*names = malloc(n)))
        return -1;
    (*names)[0] = 0;
    for (const vx_model *const *m = model_all(); *m; m++)
        strcat(strcat(*names, (*m)->name), "\n");
    return 0;
}

void vxapi_free(void *p)
{
    free(p);
}
