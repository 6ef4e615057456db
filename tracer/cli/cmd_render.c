/* voxlab render SCENE --model M (--res N [--rays K] | --vox FILE) [--spp N] [--size WxH] [--seed S]
 *               [--threads T] [--no-cache] [--no-shadow-skip] [--backend c|opencl] -o OUT [--stats S.json] */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bake.h"
#include "cli.h"
#include "commands.h"
#include "estimate.h"
#include "fileio.h"
#include "opencl_backend.h"
#include "parallel.h"
#include "render.h"
#include "vox_load.h"
#include "voxfile.h"

static const char usage[] =
    "usage: voxlab render SCENE --model M (--res N [--rays K] | --vox FILE) [--spp N] [--size WxH] [--seed S]\n"
    "                     [--threads T] [--no-cache] [--no-shadow-skip] [--backend c|opencl] [--dry-run]\n"
    "                     -o OUT.exr|OUT.png [--stats S.json]\n";

int cmd_render(int argc, char **argv)
{
    const char *scene_path = NULL, *out_path = NULL, *stats_path = NULL, *model_name = NULL, *vox = NULL,
               *size = NULL;
    int opencl = 0; /* --backend opencl */
    int dry_run = 0;
    render_options o;
    render_default_options(&o);
    bake_options bo = {.rays = 150, .seed = 1, .progress = 1};
    int res = 0;
    long long v;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *val = NULL;
        if (strcmp(a, "--no-cache") == 0) {
            o.cache = 0;
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
        else if (strcmp(a, "--size") == 0)
            size = val;
        else if (strcmp(a, "--backend") == 0) {
            if (strcmp(val, "c") != 0 && strcmp(val, "opencl") != 0) {
                fprintf(stderr, "voxlab render: --backend %s: expected c or opencl\n%s", val, usage);
                return 1;
            }
            opencl = strcmp(val, "opencl") == 0;
        }
        else if (strcmp(a, "--res") == 0) {
            if (cli_int("render", a, val, 1, GRID_MAX_N, &v))
                return 1;
            res = (int)v;
        } else if (strcmp(a, "--rays") == 0) {
            if (cli_int("render", a, val, 1, 1 << 20, &v))
                return 1;
            bo.rays = (int)v;
        } else if (strcmp(a, "--spp") == 0) {
            if (cli_int("render", a, val, 1, 1 << 16, &v))
                return 1;
            o.spp = (int)v;
        } else if (strcmp(a, "--seed") == 0) {
            if (cli_int("render", a, val, 0, 1LL << 53, &v))
                return 1;
            o.seed = bo.seed = (uint64_t)v;
        } else if (strcmp(a, "--threads") == 0) {
            if (cli_int("render", a, val, 1, 1024, &v))
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
    scene s;
    if (image_check_output(out_path, &e) || (stats_path && fileio_check_writable(stats_path, &e)) ||
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
    opencl_counts ocnt = {0};
    if (size && scene_parse_size_string(size, &o.width, &o.height, &e))
        goto fail;
    /* With --vox the resolution is the file's: the estimate covers the scene and the image, and the
     * records are allocated at the file's size (which the file system already holds). */
    vx_estimate est;
    estimate_voxels(&s, m ? m : model_all()[0], vox ? 1 : res, vox ? 0 : bo.rays, o.width, o.height, o.spp, o.cache,
                    o.threads, &est);
    if (dry_run) {
        estimate_print(stdout, "render", &est);
        rc = estimate_check(&est, &e) ? (fprintf(stdout, "  refused: %s\n", e.msg), 1) : 0;
        goto done;
    }
    if (estimate_check(&est, &e))
        goto fail;
    if (vox) {
        if (vox_load(&s, vox, model_name, &m, &g, &records, &h, &grid_seconds, &e))
            goto fail;
        bc.seconds = -1; /* not baked by this run */
        bo.rays = h.rays;
    } else if ((opencl && opencl_model_check(m, &e)) || bake_scene(&s, m, res, &bo, &g, &records, &bc, &grid_seconds, &e)) {
        goto fail;
    }
    have_grid = 1;
    if ((opencl ? render_image_opencl(&s, &g, m, records, &o, &img, &rcnt, &ocnt, &e)
                : render_image(&s, &g, m, records, &o, &img, &rcnt, &e)) ||
        image_write(&img, out_path, &e))
        goto fail;
    if (stats_path) {
        cJSON *j = stats_scene_fields(&s);
        cJSON_AddStringToObject(j, "command", "render");
        stats_add_bake(j, m, &g, &bc, bo.rays, grid_seconds);
        cJSON_AddStringToObject(j, "backend", opencl ? "opencl" : "c");
        cJSON_AddNumberToObject(j, "seconds", rcnt.seconds);
        if (opencl) {
            /* Device time is not split between traversal and model; compile time is apart from seconds. */
            cJSON_AddNullToObject(j, "traversal_seconds");
            cJSON_AddNullToObject(j, "model_seconds");
            cJSON_AddNumberToObject(j, "opencl_compile_seconds", ocnt.compile_seconds);
            cJSON_AddNumberToObject(j, "opencl_kernel_seconds", ocnt.kernel_seconds);
            cJSON_AddNumberToObject(j, "opencl_kernel_cpu_seconds", ocnt.kernel_cpu_seconds);
            cJSON_AddStringToObject(j, "opencl_device", ocnt.device);
            cJSON_AddNumberToObject(j, "opencl_compute_units", ocnt.compute_units);
        } else {
            cJSON_AddNumberToObject(j, "traversal_seconds", rcnt.traversal_seconds);
            cJSON_AddNumberToObject(j, "model_seconds", rcnt.model_seconds);
        }
        cJSON_AddNumberToObject(j, "rays", (double)rcnt.rays);
        cJSON_AddNumberToObject(j, "shadow_rays", (double)rcnt.shadow_rays);
        cJSON_AddNumberToObject(j, "voxel_visits", (double)rcnt.voxel_visits);
        cJSON_AddNumberToObject(j, "model_evals", (double)rcnt.model_evals);
        cJSON_AddNumberToObject(j, "cache_hits", (double)rcnt.cache_hits);
        cJSON_AddBoolToObject(j, "cache", o.cache);
        cJSON_AddBoolToObject(j, "shadow_skip", o.shadow_skip);
        stats_add_image(j, o.spp, o.width, o.height, o.seed, o.threads);
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
