/* voxlab render SCENE --model M (--res N [--rays K] [--param NAME=VALUE]... | --vox FILE) [--spp N]
 *               [--size WxH] [--seed S] [--threads T] [--no-cache] [--exact-view] [--no-shadow-skip]
 *               [--backend NAME] [--shadows METHOD] [--shadow-res N] [--frame F | --frames A:B]
 *               [--filter rebake|nearest|split8] -o OUT [--stats S.json] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "cli.h"
#include "commands.h"
#include "stats.h"
#include "estimate.h"
#include "fileio.h"
#include "outputs.h"
#include "backend.h"
#include "bake_params.h"
#include "parallel.h"
#include "dynamic.h"
#include "render.h"
#include "render_frames.h"
#include "vox_load.h"
#include "voxfile.h"

#define RENDER_SYNOPSIS                                                                                      \
    "voxlab render SCENE --model M (--res N [--rays K] [--param NAME=VALUE]... | --vox FILE) [--spp N]\n"         \
    "                     [--size WxH] [--seed S] [--threads T] [--no-cache] [--exact-view] [--no-shadow-skip]\n" \
    "                     [--backend c|opencl] [--shadows march|slicemap|slicemap-model|voxel] [--shadow-res N]\n" \
    "                     [--frame F | --frames A:B] [--filter rebake|nearest|split8]\n"                          \
    "                     [--dry-run] -o OUT.exr|OUT.png [--stats S.json]"
static const char usage[] = "usage: " RENDER_SYNOPSIS "\n";

const cli_command cmd_render_help = {
    "render", RENDER_SYNOPSIS,
    "Renders SCENE through a voxel model: baked here (--model, --res) or read from a .vox (--vox).",
    (const cli_option[]){
        {"-o", "OUT.exr|OUT.png", NULL, "required: the image (written atomically)"},
        {"--model", "M", NULL, "the appearance model (required with --res; with --vox, checked against the file)"},
        {"--res", "N", NULL, "bake at N^3 voxels (one of --res and --vox is required)"},
        {"--vox", "FILE", NULL, "render a baked .vox instead of baking (one of --res and --vox is required)"},
        {"--rays", "K", "150", "bake: sample rays per voxel"},
        {"--param", "NAME=VALUE", "the model's", "bake: a model parameter (repeatable)"},
        {"--spp", "N", "4", "rays per pixel (cone models: one cone per pixel)"},
        {"--size", "WxH", "the scene's", "image size"},
        {"--seed", "S", "1", "random seed of the bake and the render"},
        {"--threads", "T", "every core", "threads"},
        {"--backend", "NAME", "c", "c or opencl"},
        {"--no-cache", NULL, NULL, "evaluate every voxel per ray (default: cache each voxel's answer toward the camera)"},
        {"--exact-view", NULL, NULL, "ask each voxel's cached opacity along its own direction to the camera (default: "
         "the model's view tiles, if it asks for them: one direction per k x k pixels; vmesh: 4)"},
        {"--no-shadow-skip", NULL, NULL, "shadow rays test the voxels next to the shaded one too (default: skip 1.5 voxels)"},
        {"--shadows", "METHOD", "the scene's (march)",
         "how declared shadows are computed: march (the model's opacity per shading point), slicemap (the "
         "triangles' light-space slicemap, per-material shadow_sigma), slicemap-model (the model's opacity "
         "precomputed per light), voxel (march's shadow rays cast once per voxel and light before the frame, as "
         "Brito et al. precompute them: march's image; per-voxel models)"},
        {"--shadow-res", "N", "512; slicemap-model: 1.5 x the grid's N", "columns per side of the precomputed shadow maps"},
        {"--frame", "F", "the scene's first", "animated scenes: the frame to render"},
        {"--frames", "A:B", "none", "animated scenes: frames A to B, written as OUT_000A.exr ... (and S_000A.json)"},
        {"--filter", "NAME", "rebake", "moving objects: rebake (the posed scene baked whole), nearest or split8 "
                                      "(baked once, records transformed; models without transform re-bake, and say so)"},
        {"--dry-run", NULL, NULL, "print the memory and time estimate and stop"},
        {"--stats", "S.json", "none", "write statistics (times, rays, cache hits) as JSON"},
        {0}}};

int cmd_render(int argc, char **argv)
{
    if (cli_wants_help(argc, argv)) {
        cli_print_help(&cmd_render_help, stdout);
        return 0;
    }
    const char *scene_path = NULL, *out_path = NULL, *stats_path = NULL, *model_name = NULL, *vox = NULL,
               *size = NULL;
    const vx_backend *backend = backend_find("c");
    int dry_run = 0, param_count = 0, rays_given = 0;
    const char *param_assign[64];
    render_options o;
    render_default_options(&o);
    bake_options bo = {.rays = 150, .seed = 1, .progress = 1};
    int res = 0, filter = -1;
    frame_range fr = {0};
    long long v;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *val = NULL;
        if (strcmp(a, "--no-cache") == 0) {
            o.cache = 0;
            continue;
        }
        if (strcmp(a, "--exact-view") == 0) {
            o.view_tiles = 0;
            continue;
        }
        if (strcmp(a, "--no-shadow-skip") == 0) {
            o.shadow_skip = 0;
            continue;
        }
        if (strcmp(a, "--dry-run") == 0) {
            dry_run = 1;
            continue;
        }
        if (a[0] == '-' && !(val = cli_value("render", argc, argv, &i)))
            return 1;
        if (strcmp(a, "--model") == 0)
            model_name = val;
        else if (strcmp(a, "--vox") == 0)
            vox = val;
        else if (strcmp(a, "-o") == 0)
            out_path = val;
        else if (strcmp(a, "--stats") == 0)
            stats_path = val;
        else if (strcmp(a, "--frame") == 0 || strcmp(a, "--frames") == 0) {
            if (frames_parse("render", a, val, &fr))
                return 1;
        } else if (strcmp(a, "--filter") == 0) {
            if ((filter = dyn_filter_from_name(val)) < 0) {
                fprintf(stderr, "voxlab render: --filter %s: expected rebake, nearest or split8\n", val);
                return 1;
            }
        }
        else if (strcmp(a, "--size") == 0)
            size = val;
        else if (strcmp(a, "--shadows") == 0) {
            if ((o.shadow_method = shadow_method_from_name(val)) < 0) {
                fprintf(stderr, "voxlab render: --shadows %s: expected one of " SHADOW_METHOD_NAMES "\n%s", val,
                        usage);
                return 1;
            }
        } else if (strcmp(a, "--shadow-res") == 0) {
            if (cli_int("render", a, val, 1, SHADOW_MAX_RES, &v))
                return 1;
            o.shadow_res = (int)v;
        } else if (strcmp(a, "--param") == 0) {
            if (param_count == (int)(sizeof param_assign / sizeof *param_assign)) {
                fprintf(stderr, "voxlab render: --param given more than %d times\n", param_count);
                return 1;
            }
            param_assign[param_count++] = val;
        } else if (strcmp(a, "--backend") == 0) {
            if (!(backend = backend_find(val))) {
                fprintf(stderr, "voxlab render: --backend %s: expected one of", val);
                for (const vx_backend *const *b = backend_all(); *b; b++)
                    fprintf(stderr, " %s", (*b)->name);
                fprintf(stderr, "\n%s", usage);
                return 1;
            }
        }
        else if (strcmp(a, "--res") == 0) {
            if (cli_int("render", a, val, 1, GRID_MAX_N, &v))
                return 1;
            res = (int)v;
        } else if (strcmp(a, "--rays") == 0) {
            if (cli_int("render", a, val, 1, 1 << 20, &v))
                return 1;
            bo.rays = (int)v;
            rays_given = 1;
        } else if (strcmp(a, "--spp") == 0) {
            if (cli_int("render", a, val, 1, 1 << 16, &v))
                return 1;
            o.spp = (int)v;
        } else if (strcmp(a, "--seed") == 0) {
            if (cli_int("render", a, val, 0, 1LL << 53, &v))
                return 1;
            o.seed = bo.seed = (uint64_t)v;
        } else if (strcmp(a, "--threads") == 0) {
            if (cli_int("render", a, val, 1, CLI_MAX_THREADS, &v))
                return 1;
            o.threads = bo.threads = (int)v;
        } else if (a[0] == '-') {
            fprintf(stderr, "voxlab render: unknown option %s\n%s", a, usage);
            return 1;
        } else if (scene_path) {
            fprintf(stderr, "voxlab render: unexpected argument %s\n%s", a, usage);
            return 1;
        } else {
            scene_path = a;
        }
    }
    if (!scene_path || !out_path || (!res && !vox) || (res && vox) || (!vox && !model_name)) {
        fprintf(stderr, "voxlab render: needs SCENE, -o, and either --model M --res N or --vox FILE\n%s", usage);
        return 1;
    }
    const vx_model *m = model_name ? model_find(model_name) : NULL;
    if (model_name && !m) {
        fprintf(stderr, "voxlab render: --model %s: unknown model (see `voxlab models`)\n", model_name);
        return 1;
    }
    vx_err e;
    /* Refused rather than ignored: the image would not be what the option asked for. */
    if (vox && (param_count || rays_given)) {
        fprintf(stderr, "voxlab render: %s applies to a bake (--res); a .vox file keeps its bake's %s\n",
                param_count ? "--param" : "--rays", param_count ? "parameters" : "rays per voxel");
        return 1;
    }
    if (m && (bo.params_set = 1, bake_params_apply(m, param_assign, param_count, &bo.params, &e))) {
        fprintf(stderr, "voxlab render: %s\n", e.msg);
        return 1;
    }
    scene s;
    if (image_check_output(out_path, &e) || (stats_path && fileio_check_output("--stats", stats_path, ".json", &e)) ||
        scene_load(scene_path, &s, &e)) {
        fprintf(stderr, "voxlab render: %s\n", e.msg);
        return 1;
    }
    o.width = s.width;
    o.height = s.height;
    int rc = 1, have_grid = 0;
    voxel_grid g;
    void *records = NULL;
    bake_counts bc = {0};
    voxfile_header h;
    double grid_seconds = 0;
    image img = {0};
    render_counts rcnt;
    backend_counts bcnt = {0};
    if (frames_resolve(&s, &fr, &e) || outputs_check_scene(&s, vox, out_path, stats_path, &fr, &e) ||
        (size && scene_parse_size_string(size, &o.width, &o.height, &e)))
        goto fail;
    /* With --vox the resolution, the model, the voxels and the records are the file's header's (read
     * alone: the estimate comes before the records are read); nothing is baked or voxelised. */
    vx_estimate est;
    const vx_model *em = m;
    if (vox) {
        voxfile_header vh;
        if (voxfile_read_header(vox, &vh, &e))
            goto fail;
        if (!em && !(em = model_find(vh.model))) {
            vx_fail(&e, "%s: baked with model \"%s\", which this voxlab does not have", vox, vh.model);
            goto fail;
        }
        if (vh.n < 1 || vh.n > GRID_MAX_N) {
            vx_fail(&e, "%s: header field n (grid resolution) is %d, outside 1..%d", vox, (int)vh.n, GRID_MAX_N);
            goto fail;
        }
        estimate_vox(&s, &vh, o.width, o.height, o.spp, o.cache, o.threads, &est);
    } else
        estimate_voxels(&s, em, res, bo.rays, o.width, o.height, o.spp, o.cache, o.threads, &est);
    /* Before anything is baked or read: a shadow method the model cannot take. */
    shadow_request sr = {o.shadow_method, o.shadow_res, o.threads, NULL};
    if ((em && render_shadow_method_refused(&s, em, &o, &e)) || frames_check_shadows(&s, &fr, &sr, &e))
        goto fail;
    if (dry_run) {
        estimate_print(stdout, "render", &est);
        rc = estimate_check(&est, &e) ? (fprintf(stdout, "  refused: %s\n", e.msg), 1) : 0;
        goto done;
    }
    if (estimate_check(&est, &e))
        goto fail;
    if (fr.given || filter >= 0) { /* an animated scene's frames (render_frames.c) */
        if (vox) {
            vx_fail(&e, "--frame, --frames and --filter bake the scene per frame: they do not take --vox");
            goto fail;
        }
        if (render_frames(&s, m, res, &bo, &o, backend, out_path, stats_path, &fr, filter < 0 ? DYN_REBAKE : filter,
                          argc, argv, &e))
            goto fail;
        rc = 0;
        goto done;
    }
    if (vox) {
        if (vox_load(&s, vox, model_name, &m, &g, &records, &h, &grid_seconds, &e))
            goto fail;
        bc.seconds = -1; /* not baked by this run */
        bo.rays = h.rays;
        if (bake_params_parse(m, h.params, &bo.params, &e)) {
            char why[sizeof e.msg];
            snprintf(why, sizeof why, "%s", e.msg);
            vx_fail(&e, "%s: header field params: %s", vox, why);
            have_grid = 1;
            goto fail;
        }
    } else if (backend->check(m, &o, &e) || bake_scene(&s, m, res, &bo, &g, &records, &bc, &grid_seconds, &e)) {
        goto fail;
    }
    have_grid = 1;
    image_meta meta;
    provenance_common(&meta, argc, argv, &s, o.width, o.height, o.spp, o.seed);
    image_meta_add(&meta, "renderer", "%s backend", backend->name);
    image_meta_add(&meta, "model", "%s", m->name);
    image_meta_add(&meta, "res", "%d", g.n);
    image_meta_add(&meta, "rays", "%d", bo.rays);
    char params[256];
    if (bake_params_format(m, &bo.params, params, sizeof params) == 0)
        image_meta_add(&meta, "model_params", "%s", params);
    if (vox)
        image_meta_add(&meta, "vox", "%s", vox);
    if ((vox && backend->check(m, &o, &e)) || backend->render(&s, &g, m, records, &o, &img, &rcnt, &bcnt, &e))
        goto fail;
    img.meta = &meta;
    if (image_write(&img, out_path, &e))
        goto fail;
    if (stats_path) {
        cJSON *j = stats_render(&s, m, &bo, &g, &bc, grid_seconds, backend, &o, &rcnt, &bcnt);
        if (stats_finish(j, stats_path, "render", out_path))
            goto done;
    }
    rc = 0;
    goto done;
fail:
    fprintf(stderr, "voxlab render: %s\n", e.msg);
done:
    image_free(&img);
    free(records);
    if (have_grid)
        grid_free(&g);
    scene_free(&s);
    return rc;
}
