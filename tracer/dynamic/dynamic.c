/* Voxel transformation of moving objects (dynamic.h): one bake per part, then per frame the parts'
 * records placed into the world lattice (nearest or split8), sorted by cell and merged. */
#include "dynamic.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "animation.h"
#include "bake_params.h"
#include "parallel.h"
#include "scene_tris.h"

int dyn_filter_from_name(const char *name)
{
    static const char *const names[] = {"rebake", "nearest", "split8"};
    for (int i = 0; i < 3; i++)
        if (strcmp(name, names[i]) == 0)
            return i;
    return -1;
}

const char *dyn_filter_name(int filter)
{
    return filter == DYN_NEAREST ? "nearest" : filter == DYN_SPLIT8 ? "split8" : "rebake";
}

/* Owner of every triangle (-1 static, else the moving object): objects' vertex ranges are disjoint
 * and in load order, so a binary search per triangle. */
static int *triangle_owners(const scene *s)
{
    int *own = malloc((s->mesh.triangle_count + 1) * sizeof *own);
    if (!own)
        return NULL;
    const scene_animation *a = s->anim;
    for (size_t t = 0; t < s->mesh.triangle_count; t++) {
        size_t v = s->mesh.indices[3 * t];
        int lo = 0, hi = a ? a->count : 0, found = -1;
        while (lo < hi) {
            int mid = (lo + hi) / 2;
            if (v < a->objects[mid].v0)
                hi = mid;
            else if (v >= a->objects[mid].v1)
                lo = mid + 1;
            else {
                found = mid;
                break;
            }
        }
        own[t] = found;
    }
    return own;
}

/* A scene sharing s's materials, camera and lights, holding only the triangles of `owner`. Its
 * bounds stay s's, so that the sampler's rays start where a whole bake's start. Free with
 * mesh_free(&out->mesh) only. */
static void sub_scene(const scene *s, const int *owners, int owner, scene *out)
{
    *out = *s;
    memset(&out->mesh, 0, sizeof out->mesh);
    if (owner >= 0)
        out->inst = NULL; /* instanced objects are static (they cannot be animated) */
    uint32_t *map = malloc((s->mesh.vertex_count + 1) * sizeof *map);
    if (!map)
        return; /* an empty part: the caller's bake reports it */
    memset(map, 0xff, (s->mesh.vertex_count + 1) * sizeof *map);
    const mesh *m = &s->mesh;
    for (size_t t = 0; t < m->triangle_count; t++) {
        if (owners[t] != owner)
            continue;
        uint32_t idx[3];
        for (int k = 0; k < 3; k++) {
            uint32_t v = m->indices[3 * t + (size_t)k];
            if (map[v] == UINT32_MAX) {
                const float *p = m->positions + 3 * (size_t)v, *n = m->normals + 3 * (size_t)v;
                map[v] = mesh_add_vertex(&out->mesh, v3(p[0], p[1], p[2]), v3(n[0], n[1], n[2]), m->uvs[2 * (size_t)v],
                                         m->uvs[2 * (size_t)v + 1]);
                const float *c = m->colors + 3 * (size_t)v;
                mesh_set_vertex_color(&out->mesh, map[v], v3(c[0], c[1], c[2]));
            }
            idx[k] = map[v];
        }
        mesh_add_triangle(&out->mesh, idx[0], idx[1], idx[2], m->materials[t]);
    }
    free(map);
}

int dyn_prepare(dyn_scene *d, const scene *s, const vx_model *m, int res, const bake_options *o, vx_err *e)
{
    memset(d, 0, sizeof *d);
    if (!m->transform || !m->combine)
        return vx_fail(e, "model %s has no transform/combine: moving objects are re-baked", m->name);
    d->m = m;
    d->ref_frame = s->anim ? (int)s->anim->frame : 0;
    d->parts = 1 + (s->anim ? s->anim->count : 0);
    d->part = calloc((size_t)d->parts, sizeof *d->part);
    int *owners = triangle_owners(s);
    if (!d->part || !owners) {
        free(owners);
        free(d->part);
        return vx_fail(e, "out of memory for %d moving parts", d->parts);
    }
    bake_options po = *o;
    po.progress = 0;
    d->threads = o->threads;
    if (o->params_set)
        d->params = o->params;
    else
        bake_params_defaults(m, &d->params);
    double t0 = now_seconds();
    for (int p = 0; p < d->parts; p++) {
        dyn_part *P = &d->part[p];
        if (p > 0)
            anim_pose(&s->anim->objects[p - 1], d->ref_frame, P->A, P->t);
        scene sub;
        sub_scene(s, owners, p - 1, &sub);
        if (scene_triangle_count(&sub) == 0) { /* e.g. no static geometry: an empty part */
            mesh_free(&sub.mesh);
            continue;
        }
        bake_counts bc;
        double gs;
        int rc = bake_scene(&sub, m, res, &po, &P->grid, &P->records, &bc, &gs, e);
        mesh_free(&sub.mesh);
        if (rc) {
            free(owners);
            dyn_free(d);
            return vx_wrap(e, "baking %s", p ? "a moving object" : "the static part");
        }
    }
    free(owners);
    bake_counts bc;
    double gs;
    if (bake_scene(s, m, res, &po, &d->full, &d->full_records, &bc, &gs, e)) {
        dyn_free(d);
        return vx_wrap(e, "baking the whole scene");
    }
    /* A voxel only one part touches: the whole bake's record (the same samples as the static
     * render's; a part baked alone draws others, the streams following the voxel's index). */
    size_t bytes = m->record.bytes;
    for (int p = 0; p < d->parts; p++) {
        dyn_part *P = &d->part[p];
        for (size_t i = 0; i < grid_count(&P->grid, 0); i++) {
            int x, y, z, shared = 0;
            grid_coords(&P->grid, 0, i, &x, &y, &z);
            for (int q = 0; q < d->parts && !shared; q++)
                shared = q != p && d->part[q].grid.levels && grid_index(&d->part[q].grid, 0, x, y, z) >= 0;
            int64_t j = grid_index(&d->full, 0, x, y, z);
            if (!shared && j >= 0)
                memcpy((char *)P->records + i * bytes, (const char *)d->full_records + (size_t)j * bytes, bytes);
        }
    }
    d->bake_seconds = now_seconds() - t0;
    return 0;
}

void dyn_free(dyn_scene *d)
{
    for (int p = 0; p < d->parts && d->part; p++) {
        if (d->part[p].grid.levels)
            grid_free(&d->part[p].grid);
        free(d->part[p].records);
    }
    free(d->part);
    if (d->full.levels)
        grid_free(&d->full);
    free(d->full_records);
    memset(d, 0, sizeof *d);
}

/* One part of a record put into one cell. */
typedef struct {
    uint32_t cell; /* x << 20 | y << 10 | z: sorted, the grid's dense order */
    const void *rec;
    float w;
    float off[3]; /* the record's centre minus the cell's, in cells (vx_record_part.offset) */
} piece;

typedef struct {
    piece *p;
    size_t n, cap;
    size_t dropped;
} pieces;

/* Puts rec into cell (x, y, z) with weight w, its centre at q (lattice units, cells' centres at
 * + 0.5; NULL: exactly the cell's centre). */
static int put(pieces *ps, int n, long long x, long long y, long long z, const void *rec, float w, const double *q)
{
    if (x < 0 || y < 0 || z < 0 || x >= n || y >= n || z >= n) {
        ps->dropped++;
        return 0;
    }
    if (ps->n == ps->cap) {
        size_t cap = ps->cap ? 2 * ps->cap : 4096;
        piece *grown = realloc(ps->p, cap * sizeof *grown);
        if (!grown)
            return -1;
        ps->p = grown;
        ps->cap = cap;
    }
    piece *p = &ps->p[ps->n];
    *p = (piece){(uint32_t)x << 20 | (uint32_t)y << 10 | (uint32_t)z, rec, w, {0, 0, 0}};
    if (q) {
        p->off[0] = (float)(q[0] - ((double)x + 0.5));
        p->off[1] = (float)(q[1] - ((double)y + 0.5));
        p->off[2] = (float)(q[2] - ((double)z + 0.5));
    }
    ps->n++;
    return 0;
}

/* Sorts the pieces by cell, keeping placement order within a cell (so the merge is
 * deterministic): a stable LSD radix sort on the 30-bit cell key, three passes of 10 bits, O(n)
 * where qsort's comparisons were most of a small object's transform time. */
static int sort_by_cell(pieces *ps)
{
    size_t n = ps->n;
    piece *tmp = malloc((n + 1) * sizeof *tmp);
    if (!tmp)
        return -1;
    piece *src = ps->p, *dst = tmp;
    for (int shift = 0; shift < 30; shift += 10) {
        size_t count[1025] = {0};
        for (size_t i = 0; i < n; i++)
            count[((src[i].cell >> shift) & 1023u) + 1]++;
        for (int k = 0; k < 1024; k++)
            count[k + 1] += count[k];
        for (size_t i = 0; i < n; i++)
            dst[count[(src[i].cell >> shift) & 1023u]++] = src[i];
        piece *t = src;
        src = dst;
        dst = t;
    }
    if (src == ps->p) {
        free(tmp);
    } else { /* an odd number of passes: the sorted pieces are in tmp */
        free(ps->p);
        ps->p = src;
        ps->cap = n + 1;
    }
    return 0;
}

/* The merge of a frame's cells, in parallel (each cell's parts are independent). */
typedef struct {
    const vx_model *m;
    const pieces *ps;
    const size_t *first;
    size_t cells;
    float voxel_size;
    char *out;
    vx_record_part **scratch; /* per thread, `most` parts */
} merge_job;

enum { MERGE_CELLS_PER_ITEM = 512 };

static void merge_item(void *ctx, int64_t item, int thread)
{
    merge_job *j = ctx;
    size_t bytes = j->m->record.bytes, lo = (size_t)item * MERGE_CELLS_PER_ITEM;
    vx_record_part *parts = j->scratch[thread];
    for (size_t i = lo; i < lo + MERGE_CELLS_PER_ITEM && i < j->cells; i++) {
        int n = (int)(j->first[i + 1] - j->first[i]);
        for (int k = 0; k < n; k++) {
            const piece *p = &j->ps->p[j->first[i] + (size_t)k];
            parts[k] = (vx_record_part){p->rec, p->w, {p->off[0], p->off[1], p->off[2]}};
        }
        j->m->combine(parts, n, j->voxel_size, j->out + i * bytes);
    }
}

/* Inverse of a 3x3 (row-major) by its adjugate: exact for the identity. */
static void inverse3(const double A[9], double I[9])
{
    double c0 = A[4] * A[8] - A[5] * A[7], c1 = A[5] * A[6] - A[3] * A[8], c2 = A[3] * A[7] - A[4] * A[6];
    double det = A[0] * c0 + A[1] * c1 + A[2] * c2;
    I[0] = c0 / det, I[1] = (A[2] * A[7] - A[1] * A[8]) / det, I[2] = (A[1] * A[5] - A[2] * A[4]) / det;
    I[3] = c1 / det, I[4] = (A[0] * A[8] - A[2] * A[6]) / det, I[5] = (A[2] * A[3] - A[0] * A[5]) / det;
    I[6] = c2 / det, I[7] = (A[1] * A[6] - A[0] * A[7]) / det, I[8] = (A[0] * A[4] - A[1] * A[3]) / det;
}

/* Values within 1e-6 of an integer are that integer: a motion by whole cells or quarter turns
 * then places and rotates records exactly. */
static double snap(double v)
{
    double r = nearbyint(v);
    return fabs(v - r) < 1e-6 ? r : v;
}

/* A record scaled by sc (its cube's edge, in cells) centred at q: spread over the cells its
 * (axis-aligned) cube overlaps, so that a grown object keeps no holes. split8: each cell by the
 * overlapped volume; nearest: the cells whose centres the cube holds, whole. Either way over sc
 * (a record's surface grows by sc^2 while its cube grows by sc^3: sc layers of cells share what
 * one layer held, and an alpha record keeps its opacity along a ray). Content is not rescaled. */
static int place_scaled(pieces *ps, int n, const double q[3], double sc, int filter, const void *rec)
{
    double h = 0.5 * sc;
    long long lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = (long long)floor(q[a] - h);
        hi[a] = (long long)floor(q[a] + h);
    }
    for (long long x = lo[0]; x <= hi[0]; x++)
        for (long long y = lo[1]; y <= hi[1]; y++)
            for (long long z = lo[2]; z <= hi[2]; z++) {
                long long c[3] = {x, y, z};
                double w = 1.0;
                for (int a = 0; a < 3 && w > 0; a++) {
                    if (filter == DYN_NEAREST) /* half-open: neighbours never both claim a cell */
                        w *= (double)c[a] + 0.5 - q[a] >= -h && (double)c[a] + 0.5 - q[a] < h;
                    else
                        w *= vx_fmax(0.0, vx_fmin((double)c[a] + 1.0, q[a] + h) - vx_fmax((double)c[a], q[a] - h));
                }
                if (w > 1e-9 && put(ps, n, x, y, z, rec, (float)(w / sc), q))
                    return -1;
            }
    return 0;
}

/* Places part P moved from its bake pose to pose (A, t): its records (turned by the rotation into
 * *turned, malloc'ed) as pieces. */
static int place_part(const dyn_part *P, const vx_model *m, const double A[9], const double t[3], int filter,
                      const voxel_grid *world, pieces *ps, void **turned)
{
    size_t count = grid_count(&P->grid, 0), bytes = m->record.bytes;
    *turned = NULL;
    int still = memcmp(A, P->A, sizeof P->A) == 0 && memcmp(t, P->t, sizeof P->t) == 0;
    double M[9], Ri[9], off[3], L[3];
    inverse3(P->A, Ri);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            M[3 * i + j] = A[3 * i] * Ri[j] + A[3 * i + 1] * Ri[3 + j] + A[3 * i + 2] * Ri[6 + j];
    if (still)
        for (int i = 0; i < 9; i++)
            M[i] = i % 4 == 0;
    /* World p' = M (p - t_ref) + t; in lattice units q' = M q + L. */
    const double *o = world->origin_d, vs = world->voxel_size_d;
    for (int i = 0; i < 3; i++) {
        off[i] = t[i] - (M[3 * i] * P->t[0] + M[3 * i + 1] * P->t[1] + M[3 * i + 2] * P->t[2]);
        L[i] = still ? 0.0 : snap((M[3 * i] * o[0] + M[3 * i + 1] * o[1] + M[3 * i + 2] * o[2] + off[i] - o[i]) / vs);
    }
    double det = M[0] * (M[4] * M[8] - M[5] * M[7]) - M[1] * (M[3] * M[8] - M[5] * M[6]) + M[2] * (M[3] * M[7] - M[4] * M[6]);
    double sc = cbrt(det);
    if (fabs(sc - 1.0) < 1e-6)
        sc = 1.0;
    float R[9];
    int rotated = 0;
    for (int i = 0; i < 9; i++) {
        R[i] = (float)snap(M[i] / sc);
        rotated |= R[i] != (float)(i % 4 == 0);
    }
    const char *src = P->records;
    if (rotated) {
        char *tr = malloc(count * bytes + 1);
        if (!tr)
            return -1;
        for (size_t i = 0; i < count; i++)
            m->transform(src + i * bytes, R, tr + i * bytes);
        *turned = tr;
        src = tr;
    }
    int n = world->n;
    for (size_t i = 0; i < count; i++) {
        int x, y, z;
        grid_coords(&P->grid, 0, i, &x, &y, &z);
        const void *rec = src + i * bytes;
        if (!rotated && L[0] == floor(L[0]) && L[1] == floor(L[1]) && L[2] == floor(L[2]) && sc == 1.0) {
            if (put(ps, n, x + (long long)L[0], y + (long long)L[1], z + (long long)L[2], rec, 1.0f, NULL))
                return -1;
            continue;
        }
        double c[3] = {x + 0.5, y + 0.5, z + 0.5}, q[3];
        for (int a = 0; a < 3; a++)
            q[a] = M[3 * a] * c[0] + M[3 * a + 1] * c[1] + M[3 * a + 2] * c[2] + L[a];
        if (sc != 1.0 && (filter == DYN_SPLIT8 || sc > 1.0)) {
            if (place_scaled(ps, n, q, sc, filter, rec))
                return -1;
            continue;
        }
        if (filter == DYN_NEAREST) {
            if (put(ps, n, (long long)floor(q[0]), (long long)floor(q[1]), (long long)floor(q[2]), rec, 1.0f, q))
                return -1;
            continue;
        }
        long long b[3];
        double f[3];
        for (int a = 0; a < 3; a++) {
            double u = q[a] - 0.5;
            b[a] = (long long)floor(u);
            f[a] = u - (double)b[a];
            if (f[a] < 1e-6)
                f[a] = 0;
            else if (f[a] > 1 - 1e-6)
                b[a]++, f[a] = 0;
        }
        for (int k = 0; k < 8; k++) {
            double w = 1;
            for (int a = 0; a < 3; a++)
                w *= (k >> a) & 1 ? f[a] : 1 - f[a];
            if (w > 0 && put(ps, n, b[0] + (k & 1), b[1] + ((k >> 1) & 1), b[2] + ((k >> 2) & 1), rec, (float)w, q))
                return -1;
        }
    }
    return 0;
}

int dyn_frame_parts(const dyn_scene *d, const scene *s, int frame, int filter, const int *parts, int part_count,
                    voxel_grid *g, void **records, dyn_counts *c, vx_err *e)
{
    memset(c, 0, sizeof *c);
    const vx_model *m = d->m;
    size_t bytes = m->record.bytes;
    const voxel_grid *world = NULL;
    for (int p = 0; p < d->parts && !world; p++)
        if (d->part[p].grid.levels)
            world = &d->part[p].grid;
    if (!world)
        return vx_fail(e, "the scene has no baked part");
    double t0 = now_seconds();
    /* Nothing moved (every part asked for, each at its bake pose): the whole scene's bake. */
    int still = part_count == d->parts && d->full.levels;
    for (int i = 0; i < part_count && still; i++) {
        double A[9], t[3];
        if (parts[i] == 0)
            continue;
        anim_pose(&s->anim->objects[parts[i] - 1], frame, A, t);
        still = memcmp(A, d->part[parts[i]].A, sizeof A) == 0 && memcmp(t, d->part[parts[i]].t, sizeof t) == 0;
    }
    if (still) {
        size_t n = grid_count(&d->full, 0), nrec = bake_record_count(m, &d->full);
        char *out = malloc(nrec * bytes + 1);
        if (!out)
            return vx_fail(e, "out of memory for %zu records", n);
        double tg = now_seconds();
        if (grid_build_cells(g, &d->full, d->full.level[0].coords, n, e)) {
            free(out);
            return -1;
        }
        c->grid_seconds = now_seconds() - tg;
        memcpy(out, d->full_records, nrec * bytes);
        *records = out;
        c->parts_in = c->voxels = n;
        c->transform_seconds = now_seconds() - t0 - c->grid_seconds;
        return 0;
    }
    pieces ps = {0};
    void **turned = calloc((size_t)part_count + 1, sizeof *turned);
    int rc = turned ? 0 : -1;
    for (int i = 0; i < part_count && !rc; i++) {
        int p = parts[i];
        const dyn_part *P = &d->part[p];
        if (!P->grid.levels)
            continue;
        double A[9], t[3];
        if (p == 0) {
            memcpy(A, P->A, sizeof A);
            memcpy(t, P->t, sizeof t);
        } else {
            anim_pose(&s->anim->objects[p - 1], frame, A, t);
        }
        rc = place_part(P, m, A, t, p == 0 ? DYN_NEAREST : filter, world, &ps, &turned[i]);
    }
    if (rc) {
        vx_fail(e, "out of memory placing %zu record parts", ps.n);
        goto done;
    }
    if (sort_by_cell(&ps)) {
        rc = vx_fail(e, "out of memory sorting %zu record parts", ps.n);
        goto done;
    }
    size_t cells = 0;
    uint32_t *cell = malloc((ps.n + 1) * sizeof *cell);
    size_t *first = malloc((ps.n + 2) * sizeof *first);
    if (!cell || !first) {
        free(cell);
        free(first);
        rc = vx_fail(e, "out of memory for %zu record parts", ps.n);
        goto done;
    }
    for (size_t i = 0; i < ps.n; i++)
        if (i == 0 || ps.p[i].cell != ps.p[i - 1].cell) {
            first[cells] = i;
            cell[cells++] = ps.p[i].cell;
        }
    first[cells] = ps.n;
    double tg = now_seconds();
    rc = grid_build_cells(g, world, cell, cells, e);
    c->grid_seconds = now_seconds() - tg;
    free(cell);
    char *out = rc ? NULL : calloc(bake_record_count(m, g) + 1, bytes);
    int threads = parallel_threads(d->threads);
    vx_record_part **scratch = rc ? NULL : calloc((size_t)threads, sizeof *scratch);
    if (!rc) {
        size_t most = 1;
        for (size_t i = 0; i < cells; i++)
            most = first[i + 1] - first[i] > most ? first[i + 1] - first[i] : most;
        int ok = out && scratch;
        for (int t = 0; ok && t < threads; t++)
            ok = (scratch[t] = malloc(most * sizeof **scratch)) != NULL;
        if (!ok) {
            grid_free(g);
            rc = vx_fail(e, "out of memory for %zu records", cells);
        }
    }
    if (!rc) {
        merge_job j = {m, &ps, first, cells, g->voxel_size, out, scratch};
        parallel_for((int64_t)((cells + MERGE_CELLS_PER_ITEM - 1) / MERGE_CELLS_PER_ITEM), threads, merge_item, &j, NULL);
    }
    for (int t = 0; scratch && t < threads; t++)
        free(scratch[t]);
    free(scratch);
    free(first);
    /* A model with levels: the coarser levels from the moved level 0, as its bake builds them. */
    if (!rc && m->record.levels && m->bake_finish(g, out, &d->params)) {
        grid_free(g);
        rc = vx_fail(e, "model %s: bake_finish failed on the moved records", m->name);
    }
    if (rc) {
        free(out);
    } else {
        *records = out;
        c->parts_in = ps.n;
        c->voxels = cells;
        c->dropped = ps.dropped;
    }
done:
    for (int i = 0; turned && i < part_count; i++)
        free(turned[i]);
    free(turned);
    free(ps.p);
    c->transform_seconds = now_seconds() - t0 - c->grid_seconds;
    return rc;
}

int dyn_frame(const dyn_scene *d, const scene *s, int frame, int filter, voxel_grid *g, void **records, dyn_counts *c,
              vx_err *e)
{
    int *parts = malloc((size_t)d->parts * sizeof *parts);
    if (!parts)
        return vx_fail(e, "out of memory");
    for (int p = 0; p < d->parts; p++)
        parts[p] = p;
    int rc = dyn_frame_parts(d, s, frame, filter, parts, d->parts, g, records, c, e);
    free(parts);
    return rc;
}

int dyn_rebake_moving(const scene *s, const vx_model *m, int res, const bake_options *o, double *seconds, vx_err *e)
{
    int *owners = triangle_owners(s);
    if (!owners)
        return vx_fail(e, "out of memory");
    /* Every moving triangle at once: owners mapped to 0 (moving) and -1 (static). */
    for (size_t t = 0; t < s->mesh.triangle_count; t++)
        owners[t] = owners[t] >= 0 ? 0 : -1;
    scene sub;
    sub_scene(s, owners, 0, &sub);
    free(owners);
    bake_options po = *o;
    po.progress = 0;
    voxel_grid g;
    void *records = NULL;
    bake_counts bc;
    double gs, t0 = now_seconds();
    int rc = sub.mesh.triangle_count ? bake_scene(&sub, m, res, &po, &g, &records, &bc, &gs, e)
                                     : vx_fail(e, "the scene has no moving object");
    *seconds = now_seconds() - t0;
    mesh_free(&sub.mesh);
    if (!rc) {
        free(records);
        grid_free(&g);
    }
    return rc;
}
