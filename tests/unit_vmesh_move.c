/* `vmesh` moving records (issue 17; models/vmesh/vmesh_move.c): the identity and one whole part are
 * bit-exact; a record turned a quarter turn about x opacities like the record baked from the turned
 * samples (and the unturned one does not); a record merged with itself at weights 1/2 answers like
 * it; a subgrid moved by 0.34 cells moves its occupied sub-cells by one; split8's eight pieces keep
 * the record's opacity-weighted coverage; and a model without transform/combine still renders
 * --filter split8 by re-baking (render_frames, as `voxlab render` does), saying so in its stats. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "backend.h"
#include "dynamic.h"
#include "render_frames.h"
#include "plane_samples.h"
#include "unit.h"
#include "vmesh_bake.h"
#include "vmesh_eval.h"

static uint64_t rs = 777;
static double rnd(void)
{
    rs = rs * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(rs >> 11) * (1.0 / 9007199254740992.0);
}

static vec3 rot(const float R[9], vec3 v)
{
    return v3(R[0] * v.x + R[1] * v.y + R[2] * v.z, R[3] * v.x + R[4] * v.y + R[5] * v.z,
              R[6] * v.x + R[7] * v.y + R[8] * v.z);
}

static vx_query query_toward(vec3 w)
{
    vx_query q;
    memset(&q, 0, sizeof q);
    q.ray_dir = w;
    q.to_viewer = v3_scale(w, -1);
    q.ray_origin = v3_scale(w, -2);
    q.t0 = 1.5f, q.t1 = 2.5f;
    q.voxel_lo = v3(-0.5f, -0.5f, -0.5f);
    q.voxel_size = 1;
    q.footprint = 0.01f;
    q.light_count = 1;
    q.to_light[0] = v3_normalize(v3(0.3f, 0.9f, 0.3f));
    q.irradiance[0] = v3(3, 3, 3);
    return q;
}

static vec3 random_dir(void)
{
    double z = 2 * rnd() - 1, ph = 2 * M_PI * rnd(), r = sqrt(1 - z * z);
    return v3((float)(r * cos(ph)), (float)(r * sin(ph)), (float)z);
}

enum { N = 600 };
static vx_sample samples[N], turned[N];

static void bake(const vx_sample *s, vmesh_record *r)
{
    vx_voxel v = {.lo = v3(-0.5f, -0.5f, -0.5f), .size = 1};
    memset(r, 0, sizeof *r);
    vmesh_bake_voxel(&v, s, N, r);
}

static void check_identity(const vmesh_record *a)
{
    static const float I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    vmesh_record t;
    vmesh_transform(a, I, &t);
    CHECK("vmesh: transform by the identity is bit-exact", memcmp(&t, a, sizeof t) == 0);
    vx_record_part one = {a, 1.0f, {0, 0, 0}};
    vmesh_combine(&one, 1, 0.25f, &t);
    CHECK("vmesh: combine of one part (weight 1, offset 0) is bit-exact", memcmp(&t, a, sizeof t) == 0);
}

/* A quarter turn about x (unit_dynamic.c turns about z, for every model). */
static void check_turn(const vmesh_record *a)
{
    const float R[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0};
    for (int i = 0; i < N; i++) {
        turned[i] = samples[i];
        turned[i].origin = rot(R, samples[i].origin);
        turned[i].dir = rot(R, samples[i].dir);
        turned[i].normal = rot(R, samples[i].normal);
    }
    vmesh_record b, t;
    bake(turned, &b);
    vmesh_transform(a, R, &t);
    double worst = 0, unturned = 0;
    for (int i = 0; i < 64; i++) {
        vec3 w = random_dir();
        float want = vmesh_opacity_along(&b, w);
        worst = fmax(worst, fabs(vmesh_opacity_along(&t, w) - want));
        unturned = fmax(unturned, fabs(vmesh_opacity_along(a, w) - want));
    }
    CHECK_NEAR("vmesh: a record turned 90 degrees about x opacities like the turned bake (64 directions)", worst, 0, 0.02);
    CHECK("vmesh: (the unturned record differs by more than 0.05)", unturned > 0.05);
    int diff = 0;
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        diff = abs(t.opacity[c] - b.opacity[c]) > diff ? abs(t.opacity[c] - b.opacity[c]) : diff;
    printf("# quarter turn: opacity error %.4f (unturned %.4f), subgrid bytes off by at most %d\n", worst, unturned, diff);
    CHECK("vmesh: a quarter turn permutes the subgrid like the turned bake's (bytes within 2)", diff <= 2);
    /* The faces turn too: the turned record's mean front normal is the turned bake's. */
    vmesh_octahedron ot = vmesh_decode_octahedron(&t), ob = vmesh_decode_octahedron(&b);
    CHECK_NEAR("vmesh: its first axis is the turned bake's (up to sign)", fabs(v3_dot(ot.axis[0], ob.axis[0])), 1, 0.01);
}

static void check_halves(const vmesh_record *a)
{
    vx_record_part halves[2] = {{a, 0.5f, {0, 0, 0}}, {a, 0.5f, {0, 0, 0}}};
    vmesh_record h;
    vmesh_combine(halves, 2, 1.0f, &h);
    double worst_a = 0, worst_c = 0;
    for (int i = 0; i < 64; i++) {
        vec3 w = random_dir();
        vx_query q = query_toward(w);
        worst_a = fmax(worst_a, fabs(vmesh_opacity_along(&h, w) - vmesh_opacity_along(a, w)));
        vec3 x = vmesh_shade_record(&h, &q), y = vmesh_shade_record(a, &q);
        worst_c = fmax(worst_c, fmax(fabs(x.x - y.x), fmax(fabs(x.y - y.y), fabs(x.z - y.z))));
    }
    printf("# halves: opacity error %.4f, radiance error %.4f\n", worst_a, worst_c);
    CHECK_NEAR("vmesh: a record merged with itself at weights 1/2 has its opacities (64 directions)", worst_a, 0, 0.01);
    CHECK_NEAR("vmesh: ... and its radiance (64 directions, irradiance 3)", worst_c, 0, 0.03);
    char why[200] = "";
    vx_record_context c = {0, 1.0f, N};
    CHECK("vmesh: the merged record is valid", model_find("vmesh")->validate_record(&h, &c, why, sizeof why) == 0);
}

static void check_shift(void)
{
    vmesh_record a;
    memset(&a, 0, sizeof a);
    for (int j = 0; j < 3; j++) /* a slab of sub-cells at x index 1 */
        for (int k = 0; k < 3; k++)
            a.opacity[(1 * 3 + j) * 3 + k] = 200;
    /* split8's piece: the weight is the volume its unit cube overlaps the cell (0.66). */
    vx_record_part p = {&a, 0.66f, {0.34f, 0, 0}};
    vmesh_record s;
    vmesh_combine(&p, 1, 1.0f, &s);
    int moved = 1;
    for (int c = 0; c < VMESH_SUBCELLS; c++) {
        int i = c / 9, want = i == 2; /* the slab one sub-cell further along +x */
        moved &= (s.opacity[c] > 128) == want;
    }
    CHECK("vmesh: a split piece's subgrid moved by (0.34, 0, 0) cells moves its occupied sub-cells by one along x",
          moved);
    CHECK_NEAR("vmesh: ... keeping their opacity (200 of 255, 2 % left behind)", s.opacity[(2 * 3 + 1) * 3 + 1], 196, 2);
    /* nearest's record, placed whole (weight 1), snaps into the cell as the dynamic-SVO paper's
     * nearest filtering does: unshifted, whatever its offset. Shifted, a record moved by half a cell
     * on each axis kept an eighth of its subgrid (the fidelity audit). */
    vx_record_part whole = {&a, 1.0f, {0.5f, 0.5f, 0.5f}};
    vmesh_combine(&whole, 1, 1.0f, &s);
    int same = 1;
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        same &= abs((int)s.opacity[c] - (int)a.opacity[c]) <= 1;
    CHECK("vmesh: a record placed whole (nearest, offset (0.5, 0.5, 0.5)) keeps its subgrid unshifted", same);
}

/* A scaled object's placement (tracer/dynamic/: scale 2 spreads a record over the cells its cube
 * of edge 2 overlaps, weight = covered volume / 2): a cell more than one cell from the record's
 * centre still gets its content (no hole), thinned, so that two such cells give each sub-cell's
 * coverage. */
static void check_scaled(const vmesh_record *a)
{
    vx_record_part p = {a, 0.5f, {1.2f, 0.3f, -0.4f}};
    vmesh_record s;
    vmesh_combine(&p, 1, 1.0f, &s);
    double worst = 0;
    for (int c = 0; c < VMESH_SUBCELLS; c++) {
        double t = 1.0 - s.opacity[c] / 255.0;
        worst = fmax(worst, fabs(t * t - (1.0 - a->opacity[c] / 255.0)));
    }
    CHECK_NEAR("vmesh: a scale-2 placement beyond the unit cube (offset 1.2 cells, weight 1/2) keeps its sub-cells, "
               "two cells' worth giving each sub-cell's opacity", worst, 0, 0.01);
}

/* The record's centre at q (cell units from the lower cell's centre) split over the 8 cells around
 * it by trilinear weights, each cell holding its piece alone (split8). */
static void check_split(const vmesh_record *a)
{
    const double q[3] = {0.3, 0.65, 0.15};
    double before = 0, after = 0;
    for (int c = 0; c < VMESH_SUBCELLS; c++)
        before += a->opacity[c];
    int valid = 1;
    for (int k = 0; k < 8; k++) {
        double w = 1;
        float off[3];
        for (int ax = 0; ax < 3; ax++) {
            int up = (k >> ax) & 1;
            w *= up ? q[ax] : 1 - q[ax];
            off[ax] = (float)(q[ax] - up);
        }
        vx_record_part p = {a, (float)w, {off[0], off[1], off[2]}};
        vmesh_record s;
        vmesh_combine(&p, 1, 1.0f, &s);
        for (int c = 0; c < VMESH_SUBCELLS; c++)
            after += s.opacity[c];
        char why[200] = "";
        vx_record_context ctx = {0, 1.0f, N};
        valid &= model_find("vmesh")->validate_record(&s, &ctx, why, sizeof why) == 0;
    }
    printf("# split8: total sub-cell opacity %.0f -> %.0f\n", before, after);
    CHECK_NEAR("vmesh: split8's 8 pieces keep the record's total sub-cell opacity (ratio)", after / before, 1.0, 0.03);
    CHECK("vmesh: ... and each piece is a valid record", valid);
}

/* A whole file, NUL-terminated (NULL when unreadable). */
static char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, len = 0;
    char *buf = malloc(cap + 1);
    size_t got;
    while (buf && (got = fread(buf + len, 1, cap - len, f)) > 0) {
        len += got;
        if (len == cap) {
            char *grown = realloc(buf, 2 * cap + 1);
            if (!grown) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = grown;
            cap *= 2;
        }
    }
    fclose(f);
    if (buf)
        buf[len] = 0;
    *n = len;
    return buf;
}

/* --filter split8 with a model that cannot move its records: a copy of vmesh without
 * transform/combine, through render_frames as `voxlab render` calls it. */
static void check_fallback(void)
{
    const char *tmp = getenv("TEST_TMP");
    char dir[512], scene_path[600], out_a[600], out_b[600], stats[600], err_path[600];
    snprintf(dir, sizeof dir, "%s", tmp && *tmp ? tmp : "/tmp");
    char cmd[700];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", dir);
    if (system(cmd) != 0)
        return;
    snprintf(scene_path, sizeof scene_path, "%s/fallback.json", dir);
    snprintf(out_a, sizeof out_a, "%s/fallback_split8.exr", dir);
    snprintf(out_b, sizeof out_b, "%s/fallback_rebake.exr", dir);
    snprintf(stats, sizeof stats, "%s/fallback_stats.json", dir);
    snprintf(err_path, sizeof err_path, "%s/fallback.stderr", dir);
    char plate[4096];
    if (!realpath("scenes/meshes/plate.ply", plate)) {
        CHECK("fallback: scenes/meshes/plate.ply found (run from the repository root)", 0);
        return;
    }
    FILE *f = fopen(scene_path, "w");
    fprintf(f,
            "{\"name\": \"fallback\", \"size\": [24, 24], \"background\": [0.3, 0.4, 0.5], \"frames\": [0, 4],\n"
            " \"camera\": {\"position\": [0, 2.2, 3.4], \"look_at\": [0, 0.3, 0], \"up\": [0, 1, 0], \"fov_deg\": 45},\n"
            " \"lights\": [{\"type\": \"directional\", \"direction\": [0.4, 1, 0.3], \"irradiance\": [3, 3, 3]}],\n"
            " \"materials\": {\"g\": {\"color\": [0.7, 0.7, 0.7]}},\n"
            " \"objects\": [{\"ply\": \"%s\", \"material\": \"g\", \"transform\": {\"scale\": [3, 1, 3]}},\n"
            "  {\"ply\": \"%s\", \"material\": \"g\", \"transform\": {\"translate\": [0, 0.8, 0]},\n"
            "   \"animation\": {\"keys\": [{\"frame\": 0}, {\"frame\": 4, \"rotate_deg\": [0, 90, 30]}]}}]}\n",
            plate, plate);
    fclose(f);
    vx_model still = *model_find("vmesh");
    still.transform = NULL;
    still.combine = NULL;
    scene s;
    vx_err e;
    if (scene_load(scene_path, &s, &e)) {
        printf("not ok fallback: the scene loads: %s\n", e.msg);
        unit_failures++;
        return;
    }
    bake_options bo = {.rays = 32, .seed = 1, .threads = 1};
    render_options o;
    render_default_options(&o);
    o.width = o.height = 24;
    o.spp = 1;
    o.threads = 1;
    frame_range fr = {.given = 1, .first = 2, .last = 2};
    char *argv[] = {"unit_vmesh_move", NULL};
    /* stderr into a file for the duration of the call: the fallback must be said there. */
    fflush(stderr);
    int saved = dup(2);
    FILE *ef = fopen(err_path, "w");
    dup2(fileno(ef), 2);
    int rc = render_frames(&s, &still, 12, &bo, &o, backend_find("c"), out_a, stats, &fr, DYN_SPLIT8, 1, argv, &e);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    fclose(ef);
    int rc2 = render_frames(&s, &still, 12, &bo, &o, backend_find("c"), out_b, NULL, &fr, DYN_REBAKE, 1, argv, &e);
    CHECK("fallback: render_frames --filter split8 with a model without transform/combine succeeds", rc == 0 && rc2 == 0);
    size_t n_err = 0, n_st = 0, n_a = 0, n_b = 0;
    char *err = NULL, *st = NULL, *ia = NULL, *ib = NULL;
    err = slurp(err_path, &n_err);
    st = slurp(stats, &n_st);
    ia = slurp(out_a, &n_a);
    ib = slurp(out_b, &n_b);
    CHECK("fallback: ... says \"falling back to rebake\" on stderr", err && strstr(err, "falling back to rebake"));
    CHECK("fallback: ... and in --stats (filter split8, filter_used rebake, fallback)",
          st && strstr(st, "\"filter\":\t\"split8\"") && strstr(st, "\"filter_used\":\t\"rebake\"") && strstr(st, "\"fallback\""));
    CHECK("fallback: ... and renders the re-bake's image, byte for byte", ia && ib && n_a == n_b && memcmp(ia, ib, n_a) == 0);
    if (st && !strstr(st, "\"filter_used\":\t\"rebake\""))
        printf("# stats: %s\n", st);
    free(err), free(st), free(ia), free(ib);
    scene_free(&s);
}

int main(void)
{
    plane_samples(v3_normalize(v3(0.3f, 0.8f, 0.52f)), 0.12f, 0.04f, N, rnd, samples);
    vmesh_record a;
    bake(samples, &a);
    check_identity(&a);
    check_turn(&a);
    check_halves(&a);
    check_shift();
    check_split(&a);
    check_scaled(&a);
    check_fallback();
    return unit_exit();
}
