/* voxlab bake SCENE --model M --res N [--rays K] [--seed S] [--threads T] -o OUT.vox [--stats S.json]
 * and the shared bake step of `voxlab render --res N`. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "bake.h"
#include "cli.h"
#include "commands.h"
#include "estimate.h"
#include "fileio.h"
#include "parallel.h"
#include "voxfile.h"

double peak_rss_bytes(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_maxrss * 1024.0; /* Linux reports kilobytes */
}

int bake_scene(const scene *s, const vx_model *m, int res, const bake_options *o, voxel_grid *g, void **records,
               bake_counts *counts, double *grid_seconds, vx_err *e)
{
    double t0 = now_seconds();
    if (grid_build(g, &s->mesh, res, e))
        return -1;
    *grid_seconds = now_seconds() - t0;
    rt_scene rt;
    if (rt_build(&rt, s, e)) {
        grid_free(g);
        return -1;
    }
    int rc = bake_run(&rt, g, m, o, records, counts, e);
    rt_free(&rt);
    if (rc)
        grid_free(g);
    return rc;
}

void stats_add_bake(cJSON *j, const vx_model *m, const voxel_grid *g, const bake_counts *c, int rays,
                    double grid_seconds)
{
    cJSON_AddStringToObject(j, "model", m->name);
    cJSON_AddNumberToObject(j, "res", g->n);
    cJSON_AddNumberToObject(j, "voxels", (double)grid_count(g, 0));
    cJSON_AddNumberToObject(j, "bytes_per_voxel", (double)m->voxel_bytes);
    cJSON_AddNumberToObject(j, "records", (double)bake_record_count(m, g));
    cJSON_AddNumberToObject(j, "model_bytes", (double)(bake_record_count(m, g) * m->voxel_bytes));
    cJSON_AddNumberToObject(j, "grid_bytes", (double)grid_bytes(g));
    cJSON_AddNumberToObject(j, "grid_seconds", grid_seconds);
    if (c->seconds < 0) /* rendered from a .vox file: the bake's time is in that bake's --stats */
        cJSON_AddNullToObject(j, "bake_seconds");
    else
        cJSON_AddNumberToObject(j, "bake_seconds", c->seconds + c->finish_seconds);
    cJSON_AddNumberToObject(j, "bake_rays", (double)c->rays);
    cJSON_AddNumberToObject(j, "rays_per_voxel", rays);
}

int cmd_bake(int argc, char **argv)
{
    static const char usage[] =
        "usage: voxlab bake SCENE --model M --res N [--rays K] [--seed S] [--threads T] [--dry-run] -o OUT.vox\n"
        "                   [--stats S.json]\n";
    const char *scene_path = NULL, *out_path = NULL, *stats_path = NULL, *model_name = NULL;
    bake_options o = {.rays = 150, .seed = 1, .progress = 1};
    int res = 0, dry_run = 0;
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
            if (cli_int("bake", a, val, 1, 1024, &v))
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
    const vx_model *m = model_find(model_name);
    if (!m) {
        fprintf(stderr, "voxlab bake: --model %s: unknown model (see `voxlab models`)\n", model_name);
        return 1;
    }
    vx_err e;
    scene s;
    if (fileio_check_writable(out_path, &e) || (stats_path && fileio_check_writable(stats_path, &e)) ||
        scene_load(scene_path, &s, &e)) {
        fprintf(stderr, "voxlab bake: %s\n", e.msg);
        return 1;
    }
    int rc = 1;
    voxel_grid g;
    void *records = NULL;
    bake_counts c;
    double grid_seconds;
    vx_estimate est;
    estimate_voxels(&s, m, res, o.rays, 0, 0, 0, 0, o.threads, &est);
    if (dry_run) {
        estimate_print(stdout, "bake", &est);
        rc = estimate_check(&est, &e) ? (fprintf(stdout, "  refused: %s\n", e.msg), 1) : 0;
        scene_free(&s);
        return rc;
    }
    if (estimate_check(&est, &e) || bake_scene(&s, m, res, &o, &g, &records, &c, &grid_seconds, &e)) {
        fprintf(stderr, "voxlab bake: %s\n", e.msg);
        scene_free(&s);
        return 1;
    }
    voxfile_header h;
    memset(&h, 0, sizeof h);
    snprintf(h.model, sizeof h.model, "%s", m->name);
    h.scene_identity = s.identity;
    h.n = res;
    h.rays = o.rays;
    h.seed = o.seed;
    h.voxel_bytes = m->voxel_bytes;
    h.record_count = bake_record_count(m, &g);
    h.voxels = grid_count(&g, 0);
    if (voxfile_write(out_path, &h, records, &e)) {
        fprintf(stderr, "voxlab bake: %s\n", e.msg);
        goto done;
    }
    if (stats_path) {
        cJSON *j = stats_scene_fields(&s);
        cJSON_AddStringToObject(j, "command", "bake");
        stats_add_bake(j, m, &g, &c, o.rays, grid_seconds);
        cJSON_AddNumberToObject(j, "seconds", c.seconds + c.finish_seconds);
        cJSON_AddNumberToObject(j, "rays", (double)c.rays);
        cJSON_AddNumberToObject(j, "shadow_rays", 0);
        cJSON_AddNumberToObject(j, "bake_rays_per_second", (double)c.rays / c.seconds);
        cJSON_AddNumberToObject(j, "threads", parallel_threads(o.threads));
        cJSON_AddNumberToObject(j, "peak_rss_bytes", peak_rss_bytes());
        if (stats_finish(j, stats_path, "bake", out_path))
            goto done;
    }
    rc = 0;
done:
    free(records);
    grid_free(&g);
    scene_free(&s);
    return rc;
}

int cmd_models(int argc, char **argv)
{
    (void)argv;
    if (argc > 1) {
        fprintf(stderr, "usage: voxlab models\n");
        return 1;
    }
    for (const vx_model *const *m = model_all(); *m; m++) {
        static const char *const rules[] = {"first-hit", "alpha", "coverage"};
        printf("%-14s %4zu B/voxel  %-9s  %s\n", (*m)->name, (*m)->voxel_bytes, rules[(*m)->compositing],
               (*m)->description);
    }
    return 0;
}
