/* voxlab truth SCENE [--spp N] [--size WxH] [--seed S] [--threads T] [--shadows METHOD] [--shadow-res N]
 *              [--frame F | --frames A:B] -o OUT [--stats S.json] */
#include <cjson/cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "stats.h"
#include "estimate.h"
#include "animation.h"
#include "fileio.h"
#include "frames.h"
#include "outputs.h"
#include "parallel.h"
#include "truth.h"

#define TRUTH_SYNOPSIS                                                                                       \
    "voxlab truth SCENE [--spp N] [--size WxH] [--seed S] [--threads T] [--shadows march|slicemap]\n"             \
    "                    [--shadow-res N] [--frame F | --frames A:B] [--dry-run] -o OUT.exr|OUT.png\n"         \
    "                    [--stats S.json]"
static const char usage[] = "usage: " TRUTH_SYNOPSIS "\n";

const cli_command cmd_truth_help = {
    "truth", TRUTH_SYNOPSIS,
    "Renders SCENE's ground truth with Embree: stratified jittered rays, box filter, the scene's declared effects.",
    (const cli_option[]){
        {"-o", "OUT.exr|OUT.png", NULL, "required: the image (written atomically)"},
        {"--spp", "N", "1024", "samples per pixel"},
        {"--size", "WxH", "the scene's", "image size"},
        {"--seed", "S", "1", "random seed"},
        {"--threads", "T", "every core", "threads"},
        {"--shadows", "METHOD", "the scene's (march)",
         "how declared shadows are computed: march (Embree shadow rays) or slicemap (the triangles' light-space "
         "slicemap, per-material shadow_sigma: a comparison of shadow techniques)"},
        {"--shadow-res", "N", "512", "columns per side of the slicemap"},
        {"--frame", "F", "the scene's first", "animated scenes: the frame to render"},
        {"--frames", "A:B", "none", "animated scenes: frames A to B, written as OUT_000A.exr ... (and S_000A.json)"},
        {"--dry-run", NULL, NULL, "print the memory and time estimate and stop"},
        {"--stats", "S.json", "none", "write statistics (times, rays) as JSON"},
        {0}}};

/* Frame f of the run (the still when r is not a sequence): posed, traced, written with its
 * statistics. -1: failed, the message in e; 1: the statistics were lost (stats_finish said so and
 * removed the image). */
static int truth_frame(scene *s, const truth_options *o, const frame_range *r, int f, const char *out_path,
                       const char *stats_path, int argc, char **argv, vx_err *e)
{
    char out_f[4096], stats_f[4096];
    frames_path(out_path, f, out_f, sizeof out_f);
    if (stats_path)
        frames_path(stats_path, f, stats_f, sizeof stats_f);
    const char *out = r->sequence ? out_f : out_path, *stats = !stats_path ? NULL : r->sequence ? stats_f : stats_path;
    rt_scene rt = {0};
    image img = {0};
    truth_counts counts;
    image_meta meta;
    int rc = -1;
    if (scene_set_frame(s, f, e) || rt_build(&rt, s, e))
        goto done;
    provenance_common(&meta, argc, argv, s, o->width, o->height, o->spp, o->seed);
    image_meta_add(&meta, "renderer", "truth (Embree)");
    if (r->given)
        image_meta_add(&meta, "frame", "%d", f);
    if (truth_render(&rt, o, &img, &counts, e))
        goto done;
    img.meta = &meta;
    if (image_write(&img, out, e))
        goto done;
    rc = 0;
    if (stats) {
        cJSON *j = stats_truth(s, o, &counts);
        cJSON_AddNumberToObject(j, "bvh_bytes", (double)rt.bvh_bytes); /* Embree's peak allocation */
        cJSON_AddNumberToObject(j, "bvh_seconds", rt.bvh_seconds);     /* building it (rt_build) */
        if (r->given)
            cJSON_AddNumberToObject(j, "frame", f);
        rc = stats_finish(j, stats, "truth", out) ? 1 : 0;
    }
done:
    image_free(&img);
    rt_free(&rt);
    return rc;
}

int cmd_truth(int argc, char **argv)
{
    if (cli_wants_help(argc, argv)) {
        cli_print_help(&cmd_truth_help, stdout);
        return 0;
    }
    const char *scene_path = NULL, *out_path = NULL, *stats_path = NULL, *size = NULL;
    truth_options o = {.spp = 1024, .seed = 1, .progress = 1, .shadow_method = -1};
    int dry_run = 0;
    frame_range fr = {0};
    long long v;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *val;
        if (strcmp(a, "--dry-run") == 0)
            dry_run = 1;
        else if (strcmp(a, "--spp") == 0 || strcmp(a, "--seed") == 0 || strcmp(a, "--threads") == 0) {
            if (!(val = cli_value("truth", argc, argv, &i)))
                return 1;
            int is_seed = strcmp(a, "--seed") == 0;
            long long hi = is_seed ? (1LL << 53) : strcmp(a, "--threads") == 0 ? CLI_MAX_THREADS : 1 << 20;
            if (cli_int("truth", a, val, is_seed ? 0 : 1, hi, &v))
                return 1;
            if (strcmp(a, "--spp") == 0)
                o.spp = (int)v;
            else if (is_seed)
                o.seed = (uint64_t)v;
            else
                o.threads = (int)v;
        } else if (strcmp(a, "--frame") == 0 || strcmp(a, "--frames") == 0) {
            if (!(val = cli_value("truth", argc, argv, &i)) || frames_parse("truth", a, val, &fr))
                return 1;
        } else if (strcmp(a, "--size") == 0) {
            if (!(size = cli_value("truth", argc, argv, &i)))
                return 1;
        } else if (strcmp(a, "--shadows") == 0) {
            if (!(val = cli_value("truth", argc, argv, &i)))
                return 1;
            o.shadow_method = shadow_method_from_name(val);
            if (o.shadow_method != SHADOW_MARCH && o.shadow_method != SHADOW_SLICEMAP) {
                const char *why = truth_shadow_method_unavailable(o.shadow_method);
                fprintf(stderr, "voxlab truth: --shadows %s: expected march or slicemap%s%s%s\n%s", val, why ? " (" : "",
                        why ? why : "", why ? ")" : "", usage);
                return 1;
            }
        } else if (strcmp(a, "--shadow-res") == 0) {
            if (!(val = cli_value("truth", argc, argv, &i)) || cli_int("truth", a, val, 1, SHADOW_MAX_RES, &v))
                return 1;
            o.shadow_res = (int)v;
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
    if (image_check_output(out_path, &e) || (stats_path && fileio_check_output("--stats", stats_path, ".json", &e)) ||
        scene_load(scene_path, &s, &e)) {
        fprintf(stderr, "voxlab truth: %s\n", e.msg);
        return 1;
    }
    o.width = s.width;
    o.height = s.height;
    int rc = 1;
    shadow_request sr = truth_shadow_request(&s, &o);
    if (frames_resolve(&s, &fr, &e) || outputs_check_scene(&s, NULL, out_path, stats_path, &fr, &e) ||
        (size && scene_parse_size_string(size, &o.width, &o.height, &e)) || frames_check_shadows(&s, &fr, &sr, &e))
        goto fail;
    vx_estimate est;
    estimate_truth(&s, o.width, o.height, o.spp, o.threads, &est);
    if (dry_run) {
        estimate_print(stdout, "truth", &est);
        rc = estimate_check(&est, &e) ? (fprintf(stdout, "  refused: %s\n", e.msg), 1) : 0;
        goto done;
    }
    if (estimate_check(&est, &e))
        goto fail;
    int f = fr.first, failed = 0;
    while (f <= fr.last && !(failed = truth_frame(&s, &o, &fr, f, out_path, stats_path, argc, argv, &e)))
        f++;
    if (failed && fr.sequence) /* all or nothing: the frames written before this one go too */
        frames_remove(out_path, stats_path, fr.first, f);
    if (failed < 0 && fr.given)
        vx_wrap(&e, "frame %d", f);
    rc = failed != 0;
    if (failed >= 0)
        goto done;
fail:
    fprintf(stderr, "voxlab truth: %s\n", e.msg);
done:
    scene_free(&s);
    return rc;
}
