/* voxlab truth SCENE [--spp N] [--size WxH] [--seed S] [--threads T] -o OUT [--stats S.json] */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "estimate.h"
#include "fileio.h"
#include "parallel.h"
#include "truth.h"

static const char usage[] =
    "usage: voxlab truth SCENE [--spp N] [--size WxH] [--seed S] [--threads T] [--dry-run] -o OUT.exr|OUT.png\n"
    "                    [--stats S.json]\n";

cJSON *stats_scene_fields(const scene *s)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "scene", s->name);
    cJSON_AddNumberToObject(j, "triangles", (double)s->mesh.triangle_count);
    cJSON_AddNumberToObject(j, "degenerate_triangles", (double)s->degenerate_triangles);
    cJSON *fx = cJSON_AddArrayToObject(j, "effects");
    for (unsigned bit = 1; bit <= EFFECT_TEXTURES; bit <<= 1)
        if (s->effects & bit)
            cJSON_AddItemToArray(fx, cJSON_CreateString(effect_name(bit)));
    return j;
}

void stats_add_image(cJSON *j, int spp, int width, int height, uint64_t seed, int threads)
{
    cJSON_AddNumberToObject(j, "spp", spp);
    cJSON_AddNumberToObject(j, "width", width);
    cJSON_AddNumberToObject(j, "height", height);
    cJSON_AddNumberToObject(j, "seed", (double)seed);
    cJSON_AddNumberToObject(j, "threads", parallel_threads(threads));
    cJSON_AddNumberToObject(j, "peak_rss_bytes", peak_rss_bytes());
}

int stats_finish(cJSON *j, const char *path, const char *cmd, const char *output)
{
    char *text = cJSON_Print(j);
    cJSON_Delete(j);
    vx_err e;
    int rc = -1;
    size_t n = text ? strlen(text) : 0;
    char *line = text ? realloc(text, n + 2) : NULL;
    if (!line) {
        free(text);
        snprintf(e.msg, sizeof e.msg, "%s: out of memory for the statistics", path);
    } else {
        line[n] = '\n', line[n + 1] = 0;
        rc = fileio_write_text(path, line, &e);
        free(line);
    }
    if (rc) {
        fprintf(stderr, "voxlab %s: --stats %s\n", cmd, e.msg);
        remove(output);
    }
    return rc;
}

int cmd_truth(int argc, char **argv)
{
    const char *scene_path = NULL, *out_path = NULL, *stats_path = NULL, *size = NULL;
    truth_options o = {.spp = 1024, .seed = 1, .progress = 1};
    int dry_run = 0;
    long long v;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *val;
        if (strcmp(a, "--dry-run") == 0)
            dry_run = 1;
        else if (strcmp(a, "--spp") == 0 || strcmp(a, "--seed") == 0 || strcmp(a, "--threads") == 0) {
            if (!(val = cli_value("truth", argc, argv, &i)))
                return 1;
            int is_seed = strcmp(a, "--seed") == 0;
            if (cli_int("truth", a, val, is_seed ? 0 : 1, is_seed ? (1LL << 53) : 1 << 20, &v))
                return 1;
            if (strcmp(a, "--spp") == 0)
                o.spp = (int)v;
            else if (is_seed)
                o.seed = (uint64_t)v;
            else
                o.threads = (int)v;
        } else if (strcmp(a, "--size") == 0) {
            if (!(size = cli_value("truth", argc, argv, &i)))
                return 1;
        } else if (strcmp(a, "-o") == 0) {
            if (!(out_path = cli_value("truth", argc, argv, &i)))
                return 1;
        } else if (strcmp(a, "--stats") == 0) {
            if (!(stats_path = cli_value("truth", argc, argv, &i)))
                return 1;
        } else if (a[0] == '-' || scene_path) {
            fprintf(stderr, "voxlab truth: unexpected argument %s\n%s", a, usage);
            return 1;
        } else {
            scene_path = a;
        }
    }
    if (!scene_path || !out_path) {
        fprintf(stderr, "voxlab truth: %s\n%s", scene_path ? "missing -o OUT" : "missing SCENE", usage);
        return 1;
    }
    vx_err e;
    scene s;
    if (image_check_output(out_path, &e) || (stats_path && fileio_check_writable(stats_path, &e)) ||
        scene_load(scene_path, &s, &e)) {
        fprintf(stderr, "voxlab truth: %s\n", e.msg);
        return 1;
    }
    o.width = s.width;
    o.height = s.height;
    int rc = 1;
    rt_scene rt = {0};
    image img = {0};
    if (size && scene_parse_size_string(size, &o.width, &o.height, &e))
        goto fail;
    vx_estimate est;
    estimate_truth(&s, o.width, o.height, o.spp, o.threads, &est);
    if (dry_run) {
        estimate_print(stdout, "truth", &est);
        rc = estimate_check(&est, &e) ? (fprintf(stdout, "  refused: %s\n", e.msg), 1) : 0;
        goto done;
    }
    if (estimate_check(&est, &e) || rt_build(&rt, &s, &e))
        goto fail;
    truth_counts counts;
    if (truth_render(&rt, &o, &img, &counts, &e) || image_write(&img, out_path, &e))
        goto fail;
    if (stats_path) {
        cJSON *j = stats_scene_fields(&s);
        cJSON_AddStringToObject(j, "command", "truth");
        cJSON_AddNumberToObject(j, "seconds", counts.seconds);
        cJSON_AddNumberToObject(j, "rays", (double)(counts.primary_rays + counts.shadow_rays));
        cJSON_AddNumberToObject(j, "primary_rays", (double)counts.primary_rays);
        cJSON_AddNumberToObject(j, "shadow_rays", (double)counts.shadow_rays);
        cJSON_AddNumberToObject(j, "voxels", 0);
        cJSON_AddNumberToObject(j, "bytes_per_voxel", 0);
        stats_add_image(j, o.spp, o.width, o.height, o.seed, o.threads);
        if (stats_finish(j, stats_path, "truth", out_path))
            goto done;
    }
    rc = 0;
    goto done;
fail:
    fprintf(stderr, "voxlab truth: %s\n", e.msg);
done:
    image_free(&img);
    rt_free(&rt);
    scene_free(&s);
    return rc;
}
