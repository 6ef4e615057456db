/* voxlab bake SCENE --model M[,M2...] --res N [--rays K] [--seed S] [--threads T] -o OUT.vox [--stats S.json]
 * and the shared bake step of `voxlab render --res N`. Several models are baked from one pass of the
 * sampler (bake_run_models), each into its own file: OUT and S then name them with {model}. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "bake.h"
#include "bake_params.h"
#include "cli.h"
#include "commands.h"
#include "estimate.h"
#include "fileio.h"
#include "outputs.h"
#include "parallel.h"
#include "stats.h"
#include "voxfile.h"

#define BAKE_SYNOPSIS                                                                                         \
    "voxlab bake SCENE --model M[,M2...] --res N [--rays K] [--seed S] [--threads T] [--param NAME=VALUE]...\n" \
    "                   [--dry-run] -o OUT.vox [--stats S.json]"

const cli_command cmd_bake_help = {
    "bake", BAKE_SYNOPSIS,
    "Builds the voxel grid of SCENE at N^3 and bakes model M's records from the shared sampler's rays into a .vox. "
    "Several models (--model a,b,c) are baked from one pass of the sampler, each into the file its name makes of "
    "OUT's {model}: the same files as separate bakes, for about the tracing time of one.",
    (const cli_option[]){
        {"--model", "M[,M2...]", NULL, "required: the appearance model(s) (voxlab models lists them)"},
        {"--res", "N", NULL, "required: voxels per side of the grid (1..1024)"},
        {"-o", "OUT.vox", NULL,
         "required: the baked file (written atomically); with several models a path holding {model}"},
        {"--rays", "K", "150", "sample rays per voxel (Brito et al. 2023, section 3.2)"},
        {"--seed", "S", "1", "the samples' random seed"},
        {"--threads", "T", "every core", "threads"},
        {"--param", "NAME=VALUE", "the model's", "a model parameter (repeatable; voxlab models lists them; one model only)"},
        {"--dry-run", NULL, NULL, "print the memory and time estimate and stop"},
        {"--stats", "S.json", "none", "write statistics (times, bytes, rays) as JSON; with several models, {model} in it"},
        {0}}};

void bake_header_fill(voxfile_header *h, const scene *s, const vx_model *m, const bake_options *o,
                      const voxel_grid *g)
{
    memset(h, 0, sizeof *h);
    snprintf(h->model, sizeof h->model, "%s", m->name);
    h->scene_identity = s->identity;
    h->n = g->n;
    h->rays = o->rays;
    h->seed = o->seed;
    h->voxel_bytes = m->record.bytes;
    h->layout_version = (uint32_t)m->record.layout_version;
    bake_params_format(m, &o->params, h->params, sizeof h->params);
    h->record_count = bake_record_count(m, g);
    h->voxels = grid_count(g, 0);
}

/* The models of --model's comma-separated list, each known and named once. */
static int parse_models(const char *list, const vx_model **m, int *count)
{
    char name[256];
    const char *p = list;
    *count = 0;
    for (;;) {
        size_t n = strcspn(p, ",");
        if (n == 0 || n >= sizeof name) {
            fprintf(stderr, "voxlab bake: --model %s: expected model names separated by commas\n", list);
            return -1;
        }
        memcpy(name, p, n);
        name[n] = 0;
        const vx_model *md = model_find(name);
        if (!md) {
            fprintf(stderr, "voxlab bake: --model %s: unknown model (see `voxlab models`)\n", name);
            return -1;
        }
        for (int k = 0; k < *count; k++)
            if (m[k] == md) {
                fprintf(stderr, "voxlab bake: --model %s: %s is named twice\n", list, name);
                return -1;
            }
        if (*count == BAKE_MAX_MODELS) {
            fprintf(stderr, "voxlab bake: --model %s: more than %d models\n", list, BAKE_MAX_MODELS);
            return -1;
        }
        m[(*count)++] = md;
        if (!p[n])
            return 0;
        p += n + 1;
    }
}

/* pattern with every {model} replaced by m's name (pattern as is when it has none). */
static int model_path(const char *pattern, const vx_model *m, char out[4096])
{
    size_t len = 0;
    for (const char *p = pattern; *p;) {
        const char *piece = p;
        size_t n = 1;
        if (strncmp(p, "{model}", 7) == 0) {
            piece = m->name;
            n = strlen(m->name);
            p += 7;
        } else
            p++;
        if (len + n >= 4096) {
            fprintf(stderr, "voxlab bake: %s: the path is too long\n", pattern);
            return -1;
        }
        memcpy(out + len, piece, n);
        len += n;
    }
    out[len] = 0;
    return 0;
}

/* Every model's -o and --stats against the scene's files and each other, before the bake. */
static int check_outputs(const scene *s, int count, char outs[][4096], char stats[][4096], int have_stats, vx_err *e)
{
    outputs_list l = {0};
    outputs_add_scene(&l, s);
    for (int k = 0; k < count; k++) {
        outputs_add(&l, "-o", outs[k], 1);
        if (have_stats)
            outputs_add(&l, "--stats", stats[k], 1);
    }
    int rc = outputs_check(&l, e);
    outputs_free(&l);
    return rc;
}

int cmd_bake(int argc, char **argv)
{
    static const char usage[] = "usage: " BAKE_SYNOPSIS "\n";
    if (cli_wants_help(argc, argv)) {
        cli_print_help(&cmd_bake_help, stdout);
        return 0;
    }
    const char *scene_path = NULL, *out_path = NULL, *stats_path = NULL, *model_name = NULL;
    bake_options o = {.rays = 150, .seed = 1, .progress = 1};
    int res = 0, dry_run = 0, param_count = 0;
    const char *param_assign[64];
    long long v;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *val = NULL;
        if (strcmp(a, "--dry-run") == 0) {
            dry_run = 1;
            continue;
        }
        if (a[0] == '-' && !(val = cli_value("bake", argc, argv, &i)))
            return 1;
        if (strcmp(a, "--model") == 0)
            model_name = val;
        else if (strcmp(a, "--param") == 0) {
            if (param_count == (int)(sizeof param_assign / sizeof *param_assign)) {
                fprintf(stderr, "voxlab bake: --param given more than %d times\n", param_count);
                return 1;
            }
            param_assign[param_count++] = val;
        }
        else if (strcmp(a, "-o") == 0)
            out_path = val;
        else if (strcmp(a, "--stats") == 0)
            stats_path = val;
        else if (strcmp(a, "--res") == 0) {
            if (cli_int("bake", a, val, 1, GRID_MAX_N, &v))
                return 1;
            res = (int)v;
        } else if (strcmp(a, "--rays") == 0) {
            if (cli_int("bake", a, val, 1, 1 << 20, &v))
                return 1;
            o.rays = (int)v;
        } else if (strcmp(a, "--seed") == 0) {
            if (cli_int("bake", a, val, 0, 1LL << 53, &v))
                return 1;
            o.seed = (uint64_t)v;
        } else if (strcmp(a, "--threads") == 0) {
            if (cli_int("bake", a, val, 1, CLI_MAX_THREADS, &v))
                return 1;
            o.threads = (int)v;
        } else if (a[0] == '-') {
            fprintf(stderr, "voxlab bake: unknown option %s\n%s", a, usage);
            return 1;
        } else if (scene_path) {
            fprintf(stderr, "voxlab bake: unexpected argument %s\n%s", a, usage);
            return 1;
        } else {
            scene_path = a;
        }
    }
    if (!scene_path || !out_path || !model_name || !res) {
        fprintf(stderr, "voxlab bake: SCENE, --model, --res and -o are required\n%s", usage);
        return 1;
    }
    const vx_model *m[BAKE_MAX_MODELS];
    int count = 0;
    if (parse_models(model_name, m, &count))
        return 1;
    if (count > 1 && (!strstr(out_path, "{model}") || (stats_path && !strstr(stats_path, "{model}")))) {
        fprintf(stderr, "voxlab bake: --model %s names %d models: -o%s must hold {model}, which each model's name "
                        "replaces\n",
                model_name, count, stats_path ? " and --stats" : "");
        return 1;
    }
    if (count > 1 && param_count) {
        fprintf(stderr, "voxlab bake: --param sets one model's parameter: bake models with parameters one by one\n");
        return 1;
    }
    vx_err e;
    struct vx_bake_params params[BAKE_MAX_MODELS];
    for (int k = 0; k < count; k++)
        if (bake_params_apply(m[k], param_assign, param_count, &params[k], &e)) {
            fprintf(stderr, "voxlab bake: %s\n", e.msg);
            return 1;
        }
    char outs[BAKE_MAX_MODELS][4096], stats[BAKE_MAX_MODELS][4096];
    for (int k = 0; k < count; k++) {
        if (model_path(out_path, m[k], outs[k]) || (stats_path && model_path(stats_path, m[k], stats[k])))
            return 1;
        if (fileio_check_output("-o", outs[k], ".vox", &e) ||
            (stats_path && fileio_check_output("--stats", stats[k], ".json", &e))) {
            fprintf(stderr, "voxlab bake: %s\n", e.msg);
            return 1;
        }
    }
    scene s;
    if (scene_load(scene_path, &s, &e)) {
        fprintf(stderr, "voxlab bake: %s\n", e.msg);
        return 1;
    }
    if (check_outputs(&s, count, outs, stats, stats_path != NULL, &e)) {
        fprintf(stderr, "voxlab bake: %s\n", e.msg);
        scene_free(&s);
        return 1;
    }
    int rc = 1;
    voxel_grid g;
    void *records[BAKE_MAX_MODELS] = {0};
    bake_counts c[BAKE_MAX_MODELS];
    double grid_seconds;
    /* One grid, every model's records, one model's samples. */
    vx_estimate est, more;
    estimate_voxels(&s, m[0], res, o.rays, 0, 0, 0, 0, o.threads, &est);
    for (int k = 1; k < count; k++) {
        estimate_voxels(&s, m[k], res, 0, 0, 0, 0, 0, o.threads, &more);
        est.record_bytes += more.record_bytes;
        est.total_bytes += more.record_bytes;
    }
    if (dry_run) {
        estimate_print(stdout, "bake", &est);
        rc = estimate_check(&est, &e) ? (fprintf(stdout, "  refused: %s\n", e.msg), 1) : 0;
        scene_free(&s);
        return rc;
    }
    if (estimate_check(&est, &e) ||
        bake_scene_models(&s, count, m, params, res, &o, &g, records, c, &grid_seconds, &e)) {
        fprintf(stderr, "voxlab bake: %s\n", e.msg);
        scene_free(&s);
        return 1;
    }
    int written = 0;
    for (; written < count; written++) {
        voxfile_header h;
        o.params = params[written];
        bake_header_fill(&h, &s, m[written], &o, &g);
        if (voxfile_write(outs[written], &h, records[written], g.level[0].coords, &e)) {
            fprintf(stderr, "voxlab bake: %s\n", e.msg);
            goto done;
        }
        if (stats_path) {
            cJSON *j = stats_bake(&s, m[written], &o, &g, &c[written], grid_seconds);
            if (count > 1) {
                /* One pass for all of them: bake_pass_seconds is the pass's, bake_seconds this
                 * model's part of it (the samples and its own calls; bake_counts). */
                cJSON *with = cJSON_AddArrayToObject(j, "baked_together");
                for (int k = 0; k < count; k++)
                    cJSON_AddItemToArray(with, cJSON_CreateString(m[k]->name));
            }
            if (stats_finish(j, stats[written], "bake", outs[written]))
                goto done;
        }
    }
    rc = 0;
done:
    /* A failed write leaves none of this run's files: the ones written before it are removed. */
    for (int k = 0; rc && k < written; k++) {
        remove(outs[k]);
        if (stats_path)
            remove(stats[k]);
    }
    for (int k = 0; k < count; k++)
        free(records[k]);
    grid_free(&g);
    scene_free(&s);
    return rc;
}

const cli_command cmd_models_help = {
    "models", "voxlab models [--params]",
    "Lists the appearance models, one line each (name first): bytes per voxel, compositing, description.",
    (const cli_option[]){{"--params", NULL, NULL, "list the models' parameters instead (model, name, default, range, doc)"},
                         {0}}};

int cmd_models(int argc, char **argv)
{
    if (cli_wants_help(argc, argv)) {
        cli_print_help(&cmd_models_help, stdout);
        return 0;
    }
    int params = argc == 2 && strcmp(argv[1], "--params") == 0;
    if (argc > 1 && !params) {
        fprintf(stderr, "usage: %s\n", cmd_models_help.synopsis);
        return 1;
    }
    for (const vx_model *const *m = model_all(); *m; m++) {
        static const char *const rules[] = {"first-hit", "alpha", "coverage"};
        if (!params)
            printf("%-14s %4zu B/voxel  %-9s  %s\n", (*m)->name, (*m)->record.bytes, rules[vx_model_compositing(*m)],
                   (*m)->description);
        for (const vx_param *p = (*m)->params; params && p && p->name; p++)
            if (p->is_switch)
                printf("%-14s %s=%g (0 or 1): %s\n", (*m)->name, p->name, p->fallback, p->doc);
            else
                printf("%-14s %s=%g (%g..%g): %s\n", (*m)->name, p->name, p->fallback, p->min, p->max, p->doc);
    }
    return 0;
}
