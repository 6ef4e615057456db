/* `voxlab compare A B [--json] [--heatmap OUT.png]` — the CLI face of metrics.c. JSON output is
 * for scripts and tests: one object, doubles printed with %.17g so they round-trip exactly. */
#include "cmd_compare.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "image.h"
#include "metrics.h"
#include "outputs.h"

#define COMPARE_SYNOPSIS "voxlab compare A B [--json] [--heatmap OUT.png] | voxlab compare --list-metrics"
static const char usage[] = "usage: " COMPARE_SYNOPSIS;

const cli_command cmd_compare_help = {
    "compare", COMPARE_SYNOPSIS,
    "Compares image B with reference A (EXR, PNG, PFM): MSE, PSNR and SSIM (scikit-image's definition).",
    (const cli_option[]){{"--json", NULL, NULL, "print one JSON object (doubles round-trip exactly)"},
                         {"--list-metrics", NULL, NULL, "print the metric keys --json writes, one a line, and stop"},
                         {"--heatmap", "OUT.png", "none", "write the per-pixel error as a heat map"},
                         {0}}};

static int fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("voxlab compare: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return 1;
}

/* JSON has no inf/NaN: infinite PSNR (identical images) becomes null (images with NaN or infinite
 * pixels are refused by metrics_compare). */
static size_t json_double(char *out, size_t size, const char *key, double v)
{
    int n = isfinite(v) ? snprintf(out, size, "\"%s\":%.17g,", key, v) : snprintf(out, size, "\"%s\":null,", key);
    return n < 0 ? 0 : (size_t)n;
}

/* The metrics `--json` writes, in this order: the one list of them. The experiment scripts read it
 * with `--list-metrics` (experiments/voxlab_exp/rows.py), so a metric added to image_metrics
 * (metrics.c) and named here reaches their rows, history and baseline without another edit. */
static const struct {
    const char *key;
    size_t offset;
} metric_keys[] = {
    {"mse", offsetof(image_metrics, mse)},
    {"psnr", offsetof(image_metrics, psnr)},
    {"ssim", offsetof(image_metrics, ssim)},
};
#define N_METRIC_KEYS (sizeof metric_keys / sizeof metric_keys[0])

int compare_provenance_json(const char *const paths[2], char **text, vx_err *e)
{
    image_meta meta[2];
    *text = NULL;
    if (image_read_meta(paths[0], &meta[0], e) || image_read_meta(paths[1], &meta[1], e))
        return -1;
    if (!meta[0].count && !meta[1].count)
        return 0;
    cJSON *p = cJSON_CreateObject();
    for (int i = 0; i < 2; i++) {
        cJSON *o = cJSON_AddObjectToObject(p, i ? "b" : "a");
        for (int k = 0; k < meta[i].count; k++)
            cJSON_AddStringToObject(o, meta[i].entry[k].key + strlen(IMAGE_META_PREFIX), meta[i].entry[k].value);
    }
    *text = cJSON_PrintUnformatted(p);
    cJSON_Delete(p);
    return *text ? 0 : vx_fail(e, "out of memory for the provenance");
}

char *compare_json(const image_metrics *m, int width, int height, const char *provenance)
{
    char metrics[2048];
    size_t n = 0;
    for (size_t k = 0; k < N_METRIC_KEYS && n < sizeof metrics; k++)
        n += json_double(metrics + n, sizeof metrics - n, metric_keys[k].key,
                         *(const double *)((const char *)m + metric_keys[k].offset));
    size_t size = sizeof metrics + (provenance ? strlen(provenance) : 0) + 64;
    char *out = malloc(size);
    if (out)
        snprintf(out, size, "{%s%s%s%s\"width\":%d,\"height\":%d}", metrics, provenance ? "\"provenance\":" : "",
                 provenance ? provenance : "", provenance ? "," : "", width, height);
    return out;
}

/* --heatmap naming A or B would overwrite the image it compares. */
static int check_heatmap(const char *const paths[2], const char *heatmap, vx_err *e)
{
    outputs_list l = {0};
    outputs_add(&l, "image A", paths[0], 0);
    outputs_add(&l, "image B", paths[1], 0);
    outputs_add(&l, "--heatmap", heatmap, 1);
    int rc = outputs_check(&l, e);
    outputs_free(&l);
    return rc;
}

int cmd_compare(int argc, char **argv)
{
    const char *paths[2] = {NULL, NULL}, *heatmap = NULL;
    int npaths = 0, json = 0;
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        if (strcmp(arg, "--json") == 0) {
            json = 1;
        } else if (strcmp(arg, "--list-metrics") == 0) { /* the keys --json writes, one a line */
            for (size_t k = 0; k < N_METRIC_KEYS; k++)
                puts(metric_keys[k].key);
            return fflush(stdout) == 0 ? 0 : fail("cannot write to standard output");
        } else if (strcmp(arg, "--heatmap") == 0) {
            if (i + 1 >= argc)
                return fail("--heatmap needs an output file name (e.g. --heatmap err.png)\n%s", usage);
            heatmap = argv[++i];
        } else if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            cli_print_help(&cmd_compare_help, stdout);
            return 0;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            return fail("unknown option '%s'\n%s", arg, usage);
        } else if (npaths < 2) {
            paths[npaths++] = arg;
        } else {
            return fail("unexpected argument '%s' (expected exactly two images)\n%s", arg, usage);
        }
    }
    if (npaths != 2)
        return fail("expected two images, got %d\n%s", npaths, usage);

    image a = {0}, b = {0}, heat = {0};
    vx_err e;
    int rc = 1;
    if (heatmap && image_check_output(heatmap, &e) != 0) { /* before the reads: fail before any work */
        fail("%s", e.msg);
        goto done;
    }
    if (heatmap && check_heatmap(paths, heatmap, &e)) {
        fail("%s", e.msg);
        goto done;
    }
    if (image_read(paths[0], &a, &e) != 0 || image_read(paths[1], &b, &e) != 0) {
        fail("%s", e.msg);
        goto done;
    }
    /* Checked here rather than left to metrics_compare so the message can name both files. */
    if (a.width != b.width || a.height != b.height || a.channels != b.channels) {
        fail("image sizes differ: %s is %dx%d with %d channels, %s is %dx%d with %d channels", paths[0], a.width,
             a.height, a.channels, paths[1], b.width, b.height, b.channels);
        goto done;
    }
    image_metrics m;
    if (metrics_compare(&a, &b, &m, &e) != 0) {
        fail("%s vs %s: %s", paths[0], paths[1], e.msg);
        goto done;
    }
    if (heatmap && metrics_heatmap(&a, &b, &heat, &e) != 0) {
        fail("heat map %s: %s", heatmap, e.msg);
        goto done;
    }
    if (heatmap && image_write(&heat, heatmap, &e) != 0) { /* its message names the file */
        fail("%s", e.msg);
        goto done;
    }
    if (json) {
        char *prov, *text = NULL;
        if (compare_provenance_json(paths, &prov, &e) == 0 && !(text = compare_json(&m, a.width, a.height, prov)))
            vx_fail(&e, "out of memory for the JSON");
        free(prov);
        if (!text) {
            fail("%s", e.msg);
            goto done;
        }
        puts(text);
        free(text);
    } else {
        printf("%s vs %s: %dx%d, %d channel%s%s\n", paths[0], paths[1], a.width, a.height, a.channels,
               a.channels == 1 ? "" : "s", a.channels == 2 || a.channels == 4 ? " (alpha ignored)" : "");
        if (isinf(m.psnr))
            printf("MSE %.6g  PSNR inf (identical)  SSIM %.6f\n", m.mse, m.ssim);
        else
            printf("MSE %.6g  PSNR %.2f dB  SSIM %.6f\n", m.mse, m.psnr, m.ssim);
    }
    rc = fflush(stdout) == 0 ? 0 : fail("cannot write to standard output");
done:
    image_free(&a);
    image_free(&b);
    image_free(&heat);
    return rc;
}
