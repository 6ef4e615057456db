/* Moving records (issue 17, tracer/dynamic/ and vx_model.transform/combine): a record turned by a
 * quarter turn answers like the record baked from the turned samples, for every model with
 * transform; in the world lattice, the identity is bit-exact, split8 at a whole-cell offset (and a
 * quarter turn about a cell centre) equals nearest, and split8 conserves the opacity-weighted
 * coverage (alpha) and optical mass (vicini) within 1 %. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "alpha_eval.h"
#include "animation.h"
#include "dynamic.h"
#include "grid.h"
#include "hn_record.h"
#include "model.h"
#include "plane_samples.h"
#include "unit.h"
#include "vicini_eval.h"

static uint64_t rs = 12345;
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

static float opacity_toward(const vx_model *m, const void *rec, vec3 w)
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
    return m->voxel->opacity.fn(rec, &q);
}

/* A record turned by 90 degrees about z against the record baked from the turned samples. */
static void check_quarter_turn(const vx_model *m)
{
    enum { N = 600 };
    static vx_sample a[N], b[N];
    const float R[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    plane_samples(v3_normalize(v3(0.3f, 0.8f, 0.52f)), 0.0f, 0.0f, N, rnd, a);
    for (int i = 0; i < N; i++) {
        b[i] = a[i];
        b[i].origin = rot(R, a[i].origin);
        b[i].dir = rot(R, a[i].dir);
        b[i].normal = rot(R, a[i].normal);
    }
    vx_voxel v = {.lo = v3(-0.5f, -0.5f, -0.5f), .size = 1};
    unsigned char *ra = calloc(1, m->record.bytes), *rb = calloc(1, m->record.bytes), *rt = calloc(1, m->record.bytes);
    m->bake_voxel(&v, a, N, ra);
    m->bake_voxel(&v, b, N, rb);
    m->transform(ra, R, rt);
    char name[160];
    if (m->cone) { /* a cone model has no per-voxel opacity: its plane must turn instead */
        hn_data x, y;
        hn_decode((const hn_record *)rt, 1.0f, &x);
        hn_decode((const hn_record *)rb, 1.0f, &y);
        vec3 d = v3_sub(x.n, y.n);
        snprintf(name, sizeof name, "%s: a record turned 90 degrees has the turned bake's normal (within 0.02)", m->name);
        CHECK_NEAR(name, sqrt(v3_dot(d, d)), 0, 0.02);
        snprintf(name, sizeof name, "%s: ... and its height, area and variances", m->name);
        CHECK(name, fabsf(x.h - y.h) < 0.01f && fabsf(x.area / y.area - 1) < 0.01f && fabsf(x.var_h - y.var_h) < 1e-3f &&
                        fabsf(x.var_n - y.var_n) < 1e-3f && x.two_sided == y.two_sided);
        hn_data z;
        hn_decode((const hn_record *)ra, 1.0f, &z);
        d = v3_sub(z.n, y.n);
        snprintf(name, sizeof name, "%s: (the unturned record's normal differs by more than 0.5)", m->name);
        CHECK(name, sqrt(v3_dot(d, d)) > 0.5);
        free(ra), free(rb), free(rt);
        return;
    }
    double worst = 0, worst_unturned = 0;
    for (int i = 0; i < 64; i++) {
        double z = 2 * rnd() - 1, ph = 2 * M_PI * rnd(), r = sqrt(1 - z * z);
        vec3 w = v3((float)(r * cos(ph)), (float)(r * sin(ph)), (float)z);
        float want = opacity_toward(m, rb, w);
        worst = fmax(worst, fabs(opacity_toward(m, rt, w) - want));
        worst_unturned = fmax(worst_unturned, fabs(opacity_toward(m, ra, w) - want));
    }
    snprintf(name, sizeof name, "%s: a record turned 90 degrees opacities as the record baked turned (within 0.02)", m->name);
    CHECK_NEAR(name, worst, 0, 0.02);
    /* The check can fail: for a directional model the unturned record answers otherwise. */
    if (!strcmp(m->name, "vicini") || !strcmp(m->name, "vmesh")) {
        snprintf(name, sizeof name, "%s: (the unturned record differs by more than 0.05)", m->name);
        CHECK(name, worst_unturned > 0.05);
    }
    /* The averages' mean normal turns exactly. */
    if (!strcmp(m->name, "alpha")) {
        const alpha_record *x = (const alpha_record *)rt, *y = (const alpha_record *)rb;
        double d = 0;
        for (int k = 0; k < 3; k++)
            d = fmax(d, fabs(x->normal[k] - y->normal[k]));
        CHECK_NEAR("alpha: a turned record's mean normal equals the turned bake's", d, 0, 1e-5);
    }
    free(ra);
    free(rb);
    free(rt);
}

/* ---------- the world lattice ---------- */

enum { N_WORLD = 32 };
static const double VS = 0.25;

static void lattice(voxel_grid *like)
{
    memset(like, 0, sizeof *like);
    like->n = N_WORLD;
    like->voxel_size_d = VS;
    like->voxel_size = (float)VS;
    like->levels = 1;
    for (int s = N_WORLD; s > 1; s = (s + 1) / 2)
        like->levels++;
}

/* A part from a list of cells and a record maker. */
static void make_part(dyn_part *P, const vx_model *m, const uint32_t *cells, size_t n,
                      void (*fill)(void *rec, size_t i))
{
    voxel_grid like;
    lattice(&like);
    vx_err e;
    grid_build_cells(&P->grid, &like, cells, n, &e);
    P->records = calloc(n, m->record.bytes);
    for (size_t i = 0; i < n; i++)
        fill((char *)P->records + i * m->record.bytes, i);
    memset(P->A, 0, sizeof P->A);
    P->A[0] = P->A[4] = P->A[8] = 1;
    memset(P->t, 0, sizeof P->t);
}

#define CELL(x, y, z) ((uint32_t)(x) << 20 | (uint32_t)(y) << 10 | (uint32_t)(z))

static void fill_alpha(void *rec, size_t i)
{
    alpha_record *r = rec;
    r->opacity = 0.2f + 0.7f * (float)((i * 7) % 11) / 10.0f;
    r->color[0] = 0.1f + 0.05f * (float)(i % 13), r->color[1] = 0.5f, r->color[2] = 0.3f;
    vec3 n = v3_normalize(v3((float)(i % 3) - 1.0f, 1.0f, (float)(i % 5) * 0.2f));
    r->normal[0] = n.x, r->normal[1] = n.y, r->normal[2] = n.z;
    r->roughness = 0.3f;
}

static void fill_ground(void *rec, size_t i)
{
    (void)i;
    alpha_record *r = rec;
    r->opacity = 1;
    r->color[0] = r->color[1] = r->color[2] = 0.8f;
    r->normal[1] = 1;
}

static void fill_vicini(void *rec, size_t i)
{
    vicini_record *r = rec;
    r->sigma[0] = (unsigned char)(80 + i % 100), r->sigma[1] = 255, r->sigma[2] = (unsigned char)(40 + i % 50);
    r->corr[0] = (unsigned char)(100 + i % 40), r->corr[1] = 127, r->corr[2] = (unsigned char)(110 + i % 30);
    r->density = (unsigned char)(120 + (i * 13) % 100);
    r->mix = (unsigned char)(i % 128);
    r->color[0] = 200, r->color[1] = 100, r->color[2] = (unsigned char)(i % 256);
}

typedef struct {
    scene s;
    scene_animation an;
    anim_object obj;
    anim_key keys[5];
    dyn_scene d;
    dyn_part parts[2];
} world;

/* Static ground layer y = 2; a 5^3 block of object records at 10..14; keys: frame 0 rest, 1 moved
 * by whole cells, 2 by fractions of a cell, 3 a quarter turn about y through a cell centre, 4
 * scaled by 2 about the block's centre. */
static void make_world(world *w, const vx_model *m, void (*fill)(void *, size_t))
{
    memset(w, 0, sizeof *w);
    static uint32_t ground[28 * 28], block[125];
    size_t ng = 0, nb = 0;
    for (int x = 2; x < 30; x++)
        for (int z = 2; z < 30; z++)
            ground[ng++] = CELL(x, 2, z);
    for (int x = 10; x < 15; x++)
        for (int y = 10; y < 15; y++)
            for (int z = 10; z < 15; z++)
                block[nb++] = CELL(x, y, z);
    make_part(&w->parts[0], m, ground, ng, m == model_find("alpha") ? fill_ground : fill);
    make_part(&w->parts[1], m, block, nb, fill);
    memset(w->parts[0].A, 0, sizeof w->parts[0].A); /* the static part has no pose */
    for (int k = 0; k < 5; k++) {
        w->keys[k].frame = k;
        w->keys[k].scale = 1;
        w->keys[k].q[0] = 1;
    }
    w->keys[1].t[0] = 3 * VS, w->keys[1].t[1] = -2 * VS, w->keys[1].t[2] = 5 * VS;
    w->keys[2].t[0] = 0.3 * VS, w->keys[2].t[1] = 0.55 * VS, w->keys[2].t[2] = 0.1 * VS;
    /* A quarter turn about y through the centre (12.5, *, 12.5) of the block's middle cell. */
    double h = M_PI / 4;
    w->keys[3].q[0] = cos(h), w->keys[3].q[2] = sin(h);
    double c = 12.5 * VS; /* p' = R (p - c) + c; R maps x -> -z, z -> x about y */
    w->keys[3].t[0] = c - c, w->keys[3].t[2] = c + c;
    /* Frame 4: scaled by 2 about the block's centre (12.5 cells): p' = 2 p - c. */
    w->keys[4].scale = 2;
    for (int a = 0; a < 3; a++)
        w->keys[4].t[a] = -c;
    w->obj.keys = w->keys;
    w->obj.key_count = 5;
    w->an.objects = &w->obj;
    w->an.count = 1;
    w->an.last = 4;
    w->s.anim = &w->an;
    w->d.m = m;
    w->d.parts = 2;
    w->d.part = w->parts;
}

static void free_world(world *w)
{
    for (int p = 0; p < 2; p++) {
        grid_free(&w->parts[p].grid);
        free(w->parts[p].records);
    }
}

static int frame_of(world *w, int frame, int filter, voxel_grid *g, void **rec)
{
    dyn_counts c;
    vx_err e;
    if (dyn_frame(&w->d, &w->s, frame, filter, g, rec, &c, &e)) {
        printf("# %s\n", e.msg);
        return -1;
    }
    return 0;
}

static int same_frame(const vx_model *m, const voxel_grid *a, const void *ra, const voxel_grid *b, const void *rb)
{
    if (grid_count(a, 0) != grid_count(b, 0))
        return 0;
    for (size_t i = 0; i < grid_count(a, 0); i++)
        if (a->level[0].coords[i] != b->level[0].coords[i])
            return 0;
    return memcmp(ra, rb, grid_count(a, 0) * m->record.bytes) == 0;
}

static void check_lattice(const char *model, void (*fill)(void *, size_t))
{
    const vx_model *m = model_find(model);
    world w;
    make_world(&w, m, fill);
    char name[200];
    voxel_grid gn, gs;
    void *rn = NULL, *rsp = NULL;
    size_t bytes = m->record.bytes;

    /* Frame 0: every record where it was, bit for bit, with either filter. */
    int ok = frame_of(&w, 0, DYN_SPLIT8, &gs, &rsp) == 0;
    for (size_t i = 0; ok && i < grid_count(&w.parts[1].grid, 0); i++) {
        int x, y, z;
        grid_coords(&w.parts[1].grid, 0, i, &x, &y, &z);
        int64_t j = grid_index(&gs, 0, x, y, z);
        ok = j >= 0 && memcmp((char *)rsp + (size_t)j * bytes, (char *)w.parts[1].records + i * bytes, bytes) == 0;
    }
    snprintf(name, sizeof name, "%s: identity motion (frame 0) places every record bit for bit", model);
    CHECK(name, ok && grid_count(&gs, 0) == grid_count(&w.parts[0].grid, 0) + grid_count(&w.parts[1].grid, 0));
    grid_free(&gs), free(rsp);

    /* Frame 1: whole cells; frame 3: a quarter turn about a cell centre. */
    for (int f = 1; f <= 3; f += 2) {
        ok = frame_of(&w, f, DYN_NEAREST, &gn, &rn) == 0 && frame_of(&w, f, DYN_SPLIT8, &gs, &rsp) == 0;
        snprintf(name, sizeof name, "%s: split8 equals nearest at %s", model,
                 f == 1 ? "a whole-cell offset" : "a quarter turn about a cell centre");
        CHECK(name, ok && same_frame(m, &gn, rn, &gs, rsp));
        if (f == 1) {
            int64_t j = grid_index(&gs, 0, 10 + 3, 10 - 2, 10 + 5);
            snprintf(name, sizeof name, "%s: the block's corner record moved by (3, -2, 5) cells", model);
            CHECK(name, j >= 0 && memcmp((char *)rsp + (size_t)j * bytes, w.parts[1].records, bytes) == 0);
        }
        if (f == 3 && !strcmp(model, "alpha")) { /* cell (10,10,10) -> (x', z') = (z, 25 - x) */
            int64_t j = grid_index(&gs, 0, 10, 10, 15 - 1 + 0);
            const alpha_record *in = w.parts[1].records, *out = j >= 0 ? (const alpha_record *)((char *)rsp + (size_t)j * bytes) : NULL;
            /* R about y by +90 degrees: (x, y, z) -> (z, y, -x) */
            CHECK("alpha: a quarter turn turns the mean normal",
                  out && fabsf(out->normal[0] - in->normal[2]) < 1e-6f && fabsf(out->normal[2] + in->normal[0]) < 1e-6f &&
                      out->opacity == in->opacity);
        }
        grid_free(&gn), free(rn), grid_free(&gs), free(rsp);
    }

    /* The merge runs on several threads: one thread gives the same records bit for bit. */
    w.d.threads = 1;
    ok = frame_of(&w, 2, DYN_SPLIT8, &gn, &rn) == 0;
    w.d.threads = 2;
    ok = ok && frame_of(&w, 2, DYN_SPLIT8, &gs, &rsp) == 0;
    snprintf(name, sizeof name, "%s: split8's merge on 1 and 2 threads gives the same records bit for bit", model);
    CHECK(name, ok && same_frame(m, &gn, rn, &gs, rsp));
    if (ok)
        grid_free(&gn), free(rn), grid_free(&gs), free(rsp);
    w.d.threads = 0;

    /* Frame 2: a fraction of a cell: split8 spreads each record over 8 cells and keeps the sums. */
    if (frame_of(&w, 2, DYN_SPLIT8, &gs, &rsp) == 0) {
        double in = 0, out = 0;
        size_t nin = grid_count(&w.parts[1].grid, 0);
        for (size_t i = 0; i < nin; i++) {
            const char *r = (const char *)w.parts[1].records + i * bytes;
            in += !strcmp(model, "alpha") ? ((const alpha_record *)r)->opacity
                                          : vicini_decode_density(((const vicini_record *)r)->density);
        }
        for (size_t i = 0; i < grid_count(&gs, 0); i++) {
            int x, y, z;
            grid_coords(&gs, 0, i, &x, &y, &z);
            if (y < 5) /* the ground */
                continue;
            const char *r = (const char *)rsp + i * bytes;
            out += !strcmp(model, "alpha") ? ((const alpha_record *)r)->opacity
                                           : vicini_decode_density(((const vicini_record *)r)->density);
        }
        snprintf(name, sizeof name, "%s: split8 by a fraction of a cell keeps the total %s within 1 %% (%zu -> %zu voxels)",
                 model, strcmp(model, "alpha") ? "optical mass (density)" : "opacity-weighted coverage", nin,
                 grid_count(&gs, 0) - grid_count(&w.parts[0].grid, 0));
        CHECK_NEAR(name, out / in, 1.0, 0.01);
        grid_free(&gs), free(rsp);
    } else {
        CHECK("split8 by a fraction of a cell", 0);
    }
    /* Frame 4: scaled by 2. No holes: the block's 5^3 cells fill 10^3 (nearest) and the cube's
     * 11^3 overlapped cells (split8); the opacity-weighted coverage grows as the surface, by 4. */
    if (!strcmp(model, "alpha")) {
        double in = 0;
        for (size_t i = 0; i < grid_count(&w.parts[1].grid, 0); i++)
            in += ((const alpha_record *)w.parts[1].records)[i].opacity;
        for (int filter = DYN_NEAREST; filter <= DYN_SPLIT8; filter++) {
            if (frame_of(&w, 4, filter, &gs, &rsp)) {
                CHECK("scale 2: the frame is built", 0);
                continue;
            }
            /* Record x's centre goes to 2 (x + 0.5) - 12.5 = 8.5 .. 16.5, its cube +-1 around it:
             * cells 7..16 by centres, 7..17 by overlap. */
            int lo = 7, hi = filter == DYN_NEAREST ? 16 : 17;
            size_t inside = 0, moved = 0;
            double out = 0;
            for (size_t i = 0; i < grid_count(&gs, 0); i++) {
                int x, y, z;
                grid_coords(&gs, 0, i, &x, &y, &z);
                if (y < 5)
                    continue;
                moved++;
                inside += x >= lo && x <= hi && y >= lo && y <= hi && z >= lo && z <= hi;
                out += ((const alpha_record *)rsp)[i].opacity;
            }
            size_t want = (size_t)(hi - lo + 1) * (size_t)(hi - lo + 1) * (size_t)(hi - lo + 1);
            snprintf(name, sizeof name, "alpha: scale 2 (%s) fills every cell of the grown block, no holes (%zu of %zu)",
                     dyn_filter_name(filter), inside, want);
            CHECK(name, inside == want && moved == want);
            snprintf(name, sizeof name, "alpha: scale 2 (%s): opacity-weighted coverage x4 within 1 %%",
                     dyn_filter_name(filter));
            CHECK_NEAR(name, out / in, 4.0, 0.04);
            grid_free(&gs), free(rsp);
        }
    }
    free_world(&w);
}

/* heitz-neyret's combine keeps a plane where it lies: a record moved off its cell's centre by an
 * offset (nearest's rounding), or split over 8 cells with trilinear weights, gives each cell the
 * plane at its true height above that cell's centre, and the pieces' areas add up to the whole. */
static void check_hn_offsets(void)
{
    const vx_model *m = model_find("heitz-neyret");
    enum { N = 800 };
    static vx_sample a[N];
    vec3 n0 = v3_normalize(v3(0.3f, 0.8f, 0.52f));
    plane_samples(n0, 0.0f, 0.0f, N, rnd, a);
    vx_voxel v = {.lo = v3(-0.5f, -0.5f, -0.5f), .size = 1};
    const float size = 0.25f; /* the record read in a lattice of 0.25 (h is in world units) */
    hn_record r, out;
    for (int i = 0; i < N; i++) /* the same plane in a cell of edge 0.25: scale the samples */
        a[i].origin = v3_scale(a[i].origin, size), a[i].t_entry *= size, a[i].t_exit *= size, a[i].t_hit *= size;
    v.lo = v3_scale(v.lo, size), v.size = size;
    memset(&r, 0, sizeof r);
    m->bake_voxel(&v, a, N, &r);
    hn_data d0, d;
    hn_decode(&r, size, &d0);
    vec3 N0 = v3_normalize(d0.n);
    const float off[3] = {0.3f, -0.2f, 0.45f};
    vx_record_part one = {&r, 1.0f, {off[0], off[1], off[2]}};
    m->combine(&one, 1, size, &out);
    hn_decode(&out, size, &d);
    /* A two-sided sheet's axis has no preferred sign: heights compare along N0. */
    float want = d0.h + size * (N0.x * off[0] + N0.y * off[1] + N0.z * off[2]);
    CHECK_NEAR("heitz-neyret: a record moved off the cell's centre by (0.3, -0.2, 0.45) cells keeps its plane (h, world units)",
               d.h * v3_dot(v3_normalize(d.n), N0), want, 0.002);
    CHECK_NEAR("heitz-neyret: ... and its area", d.area / d0.area, 1.0, 0.01);
    /* Split8 of the record centred at q = (0.2, 0.7, 0.4) in cell units of the cell (0,0,0)'s corner. */
    const double q[3] = {0.2 + 0.5, 0.7 + 0.5, 0.4 + 0.5};
    double area = 0, worst = 0;
    for (int k = 0; k < 8; k++) {
        double w = 1, c[3];
        for (int ax = 0; ax < 3; ax++) {
            double u = q[ax] - 0.5, b = floor(u), f = u - b;
            c[ax] = b + ((k >> ax) & 1) + 0.5;
            w *= (k >> ax) & 1 ? f : 1 - f;
        }
        vx_record_part p = {&r, (float)w, {(float)(q[0] - c[0]), (float)(q[1] - c[1]), (float)(q[2] - c[2])}};
        m->combine(&p, 1, size, &out);
        hn_decode(&out, size, &d);
        area += d.area;
        float h = d0.h + size * (N0.x * p.offset[0] + N0.y * p.offset[1] + N0.z * p.offset[2]);
        worst = fmax(worst, fabs(d.h * v3_dot(v3_normalize(d.n), N0) - h));
    }
    CHECK_NEAR("heitz-neyret: split8 gives each of the 8 cells the plane at its height", worst, 0, 0.002);
    CHECK_NEAR("heitz-neyret: split8's pieces add up to the record's area", area / d0.area, 1.0, 0.01);
}

int main(void)
{
    int with = 0;
    for (const vx_model *const *m = model_all(); *m; m++)
        if ((*m)->transform) {
            check_quarter_turn(*m);
            with++;
        }
    CHECK("at least binary, alpha and vicini have transform", with >= 3);
    check_hn_offsets();
    check_lattice("alpha", fill_alpha);
    check_lattice("vicini", fill_vicini);
    return unit_exit();
}
