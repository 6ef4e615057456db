/* Loop subdivision of one object's triangles (see mesh_subdivide.h for the rules). Each level works
 * on flat local arrays: an edge table built with an open-addressing hash of the sorted vertex pair
 * (edges numbered in order of first appearance, so the output does not depend on the hash), then
 * the edge vertices and the moved old vertices, then four triangles per triangle. */
#include "mesh_subdivide.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "json_util.h"

/* One level's geometry, vertex indices local to the object. */
typedef struct {
    float *pos, *uv, *col; /* 3, 2, 3 per vertex */
    uint32_t *idx, *mat;   /* 3 per triangle, 1 per triangle */
    size_t nv, nt;
} patch;

static void patch_free(patch *p)
{
    free(p->pos);
    free(p->uv);
    free(p->col);
    free(p->idx);
    free(p->mat);
    memset(p, 0, sizeof *p);
}

static int patch_alloc(patch *p, size_t nv, size_t nt)
{
    p->nv = nv;
    p->nt = nt;
    p->pos = malloc(nv * 3 * sizeof(float));
    p->uv = malloc(nv * 2 * sizeof(float));
    p->col = malloc(nv * 3 * sizeof(float));
    p->idx = malloc(nt * 3 * sizeof(uint32_t));
    p->mat = malloc(nt * sizeof(uint32_t));
    if (p->pos && p->uv && p->col && p->idx && p->mat)
        return 0;
    patch_free(p);
    return -1;
}

/* The edge table of one level: per half-edge (3 t + k, the edge from corner k to corner k + 1) its
 * edge; per edge its two end points, up to two opposite vertices and how many triangles share it. */
typedef struct {
    uint32_t *of_half; /* 3 per triangle */
    uint32_t *ends;    /* 2 per edge */
    uint32_t *opp;     /* 2 per edge */
    uint32_t *count;   /* 1 per edge */
    size_t ne;
} edges;

static void edges_free(edges *g)
{
    free(g->of_half);
    free(g->ends);
    free(g->opp);
    free(g->count);
    memset(g, 0, sizeof *g);
}

static uint64_t mix64(uint64_t x)
{
    /* splitmix64's finaliser: sequential vertex pairs spread over the table. */
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}

static int edges_build(const patch *p, edges *g)
{
    memset(g, 0, sizeof *g);
    size_t halves = 3 * p->nt, cap = 16;
    while (cap < 2 * halves)
        cap <<= 1;
    uint64_t *keys = malloc(cap * sizeof *keys);
    uint32_t *vals = malloc(cap * sizeof *vals);
    g->of_half = malloc((halves ? halves : 1) * sizeof *g->of_half);
    /* At most one edge per half-edge; trimmed never (the slack is at most 2x, for one level). */
    g->ends = malloc((2 * halves + 2) * sizeof *g->ends);
    g->opp = malloc((2 * halves + 2) * sizeof *g->opp);
    g->count = malloc((halves + 1) * sizeof *g->count);
    if (!keys || !vals || !g->of_half || !g->ends || !g->opp || !g->count) {
        free(keys);
        free(vals);
        edges_free(g);
        return -1;
    }
    memset(keys, 0xff, cap * sizeof *keys); /* UINT64_MAX: empty (no vertex pair has it) */
    for (size_t t = 0; t < p->nt; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = p->idx[3 * t + (size_t)k], b = p->idx[3 * t + (size_t)(k + 1) % 3];
            uint32_t c = p->idx[3 * t + (size_t)(k + 2) % 3];
            uint64_t key = a < b ? (uint64_t)a << 32 | b : (uint64_t)b << 32 | a;
            size_t slot = (size_t)mix64(key) & (cap - 1);
            while (keys[slot] != UINT64_MAX && keys[slot] != key)
                slot = (slot + 1) & (cap - 1);
            uint32_t id;
            if (keys[slot] == UINT64_MAX) {
                keys[slot] = key;
                id = vals[slot] = (uint32_t)g->ne++;
                g->ends[2 * id] = a;
                g->ends[2 * id + 1] = b;
                g->opp[2 * id] = c;
                g->opp[2 * id + 1] = c;
                g->count[id] = 1;
            } else {
                id = vals[slot];
                if (g->count[id] == 1)
                    g->opp[2 * id + 1] = c;
                g->count[id]++;
            }
            g->of_half[3 * t + (size_t)k] = id;
        }
    free(keys);
    free(vals);
    return 0;
}

/* Loop's weight for each neighbour of an interior vertex of valence n. */
static double loop_beta(int n)
{
    double c = 0.375 + 0.25 * cos(2.0 * M_PI / n);
    return (0.625 - c * c) / n;
}

/* One level: in -> out (allocated here). */
static int subdivide_once(const patch *in, patch *out)
{
    edges g;
    if (edges_build(in, &g))
        return -1;
    size_t nv = in->nv, ne = g.ne;
    /* Per old vertex: the sum and number of all its neighbours, and of those across boundary edges. */
    double *sum = calloc(nv * 6 + 1, sizeof *sum);
    uint32_t *valence = calloc(nv * 2 + 1, sizeof *valence);
    if (!sum || !valence || patch_alloc(out, nv + ne, 4 * in->nt)) {
        free(sum);
        free(valence);
        edges_free(&g);
        return -1;
    }
    for (size_t i = 0; i < ne; i++) {
        uint32_t a = g.ends[2 * i], b = g.ends[2 * i + 1];
        int boundary = g.count[i] != 2;
        for (int s = 0; s < 2; s++) {
            uint32_t v = s ? b : a, w = s ? a : b;
            double *acc = &sum[6 * (size_t)v + (boundary ? 3 : 0)];
            for (int k = 0; k < 3; k++)
                acc[k] += in->pos[3 * (size_t)w + (size_t)k];
            valence[2 * (size_t)v + (boundary ? 1 : 0)]++;
        }
        /* The edge vertex. */
        float *p = &out->pos[3 * (nv + i)];
        for (int k = 0; k < 3; k++) {
            double pa = in->pos[3 * (size_t)a + (size_t)k], pb = in->pos[3 * (size_t)b + (size_t)k];
            if (boundary)
                p[k] = (float)(0.5 * (pa + pb));
            else
                p[k] = (float)(0.375 * (pa + pb) + 0.125 * ((double)in->pos[3 * (size_t)g.opp[2 * i] + (size_t)k] +
                                                            in->pos[3 * (size_t)g.opp[2 * i + 1] + (size_t)k]));
        }
        for (int k = 0; k < 2; k++)
            out->uv[2 * (nv + i) + (size_t)k] =
                0.5f * (in->uv[2 * (size_t)a + (size_t)k] + in->uv[2 * (size_t)b + (size_t)k]);
        for (int k = 0; k < 3; k++)
            out->col[3 * (nv + i) + (size_t)k] =
                0.5f * (in->col[3 * (size_t)a + (size_t)k] + in->col[3 * (size_t)b + (size_t)k]);
    }
    /* Both counts went up once per incident edge; boundary ones are also in the boundary slots. */
    for (size_t v = 0; v < nv; v++) {
        const double *acc = &sum[6 * v];
        uint32_t n_all = valence[2 * v] + valence[2 * v + 1], n_bnd = valence[2 * v + 1];
        const float *p = &in->pos[3 * v];
        float *q = &out->pos[3 * v];
        for (int k = 0; k < 3; k++) {
            if (n_bnd == 0 && n_all >= 3) {
                double beta = loop_beta((int)n_all);
                q[k] = (float)((1.0 - n_all * beta) * p[k] + beta * (acc[k] + acc[3 + k]));
            } else if (n_bnd == 2) {
                q[k] = (float)(0.75 * p[k] + 0.125 * acc[3 + k]);
            } else {
                q[k] = p[k]; /* a corner, a non-manifold vertex, or one no triangle uses */
            }
        }
    }
    memcpy(out->uv, in->uv, nv * 2 * sizeof(float));
    memcpy(out->col, in->col, nv * 3 * sizeof(float));
    for (size_t t = 0; t < in->nt; t++) {
        const uint32_t *c = &in->idx[3 * t];
        uint32_t ab = (uint32_t)(nv + g.of_half[3 * t]), bc = (uint32_t)(nv + g.of_half[3 * t + 1]),
                 ca = (uint32_t)(nv + g.of_half[3 * t + 2]);
        const uint32_t kids[4][3] = {{c[0], ab, ca}, {ab, c[1], bc}, {ca, bc, c[2]}, {ab, bc, ca}};
        for (int j = 0; j < 4; j++) {
            memcpy(&out->idx[3 * (4 * t + (size_t)j)], kids[j], sizeof kids[j]);
            out->mat[4 * t + (size_t)j] = in->mat[t];
        }
    }
    free(sum);
    free(valence);
    edges_free(&g);
    return 0;
}

/* Grows one of the mesh's vertex arrays to hold `count` vertices of `per` floats. */
static int grow_floats(float **a, size_t count, size_t per)
{
    float *q = realloc(*a, count * per * sizeof(float));
    if (!q)
        return -1;
    *a = q;
    return 0;
}

int mesh_subdivide(mesh *m, size_t v0, size_t t0, int levels, vx_err *e)
{
    if (levels > SUBDIVIDE_MAX_LEVELS)
        return vx_fail(e, "%d levels of subdivision (at most %d)", levels, SUBDIVIDE_MAX_LEVELS);
    if (levels <= 0 || t0 >= m->triangle_count)
        return 0;
    size_t nt = m->triangle_count - t0, nv = m->vertex_count - v0;
    if (nt > (SUBDIVIDE_MAX_TRIANGLES >> (2 * levels)))
        return vx_fail(e, "%zu triangles subdivided %d times would make more than %zu triangles", nt, levels,
                       SUBDIVIDE_MAX_TRIANGLES);
    patch cur;
    if (patch_alloc(&cur, nv, nt))
        return vx_fail(e, "out of memory subdividing %zu triangles", nt);
    memcpy(cur.pos, m->positions + 3 * v0, nv * 3 * sizeof(float));
    memcpy(cur.uv, m->uvs + 2 * v0, nv * 2 * sizeof(float));
    memcpy(cur.col, m->colors + 3 * v0, nv * 3 * sizeof(float));
    memcpy(cur.mat, m->materials + t0, nt * sizeof(uint32_t));
    for (size_t i = 0; i < 3 * nt; i++) {
        uint32_t v = m->indices[3 * t0 + i];
        if (v < v0 || v >= m->vertex_count) {
            patch_free(&cur);
            return vx_fail(e, "triangle %zu uses vertex %u, outside the object's own vertices", i / 3, v);
        }
        cur.idx[i] = (uint32_t)(v - v0);
    }
    for (int l = 0; l < levels; l++) {
        patch next;
        int rc = subdivide_once(&cur, &next);
        patch_free(&cur);
        if (rc)
            return vx_fail(e, "out of memory subdividing %zu triangles (level %d of %d)", nt, l + 1, levels);
        cur = next;
    }
    /* Written back in place of the object: the mesh keeps everything before v0 and t0. */
    size_t vcount = v0 + cur.nv, tcount = t0 + cur.nt;
    if (vcount > m->vertex_capacity) {
        if (grow_floats(&m->positions, vcount, 3) || grow_floats(&m->normals, vcount, 3) ||
            grow_floats(&m->uvs, vcount, 2) || grow_floats(&m->colors, vcount, 3)) {
            patch_free(&cur);
            return vx_fail(e, "out of memory for %zu subdivided vertices", cur.nv);
        }
        m->vertex_capacity = vcount;
    }
    if (tcount > m->triangle_capacity) {
        uint32_t *ix = realloc(m->indices, tcount * 3 * sizeof(uint32_t));
        if (ix)
            m->indices = ix;
        uint32_t *mt = ix ? realloc(m->materials, tcount * sizeof(uint32_t)) : NULL;
        if (!mt) {
            patch_free(&cur);
            return vx_fail(e, "out of memory for %zu subdivided triangles", cur.nt);
        }
        m->materials = mt;
        m->triangle_capacity = tcount;
    }
    memcpy(m->positions + 3 * v0, cur.pos, cur.nv * 3 * sizeof(float));
    memcpy(m->uvs + 2 * v0, cur.uv, cur.nv * 2 * sizeof(float));
    memcpy(m->colors + 3 * v0, cur.col, cur.nv * 3 * sizeof(float));
    for (size_t i = 0; i < 3 * cur.nt; i++)
        m->indices[3 * t0 + i] = (uint32_t)(cur.idx[i] + v0);
    memcpy(m->materials + t0, cur.mat, cur.nt * sizeof(uint32_t));
    m->vertex_count = vcount;
    m->triangle_count = tcount;
    patch_free(&cur);
    mesh_smooth_normals(m, v0, t0);
    return 0;
}

int mesh_subdivide_levels(const cJSON *o, const char *where, int *levels, vx_err *e)
{
    *levels = 0;
    return json_int_in(o, "subdivide", where, 0, SUBDIVIDE_MAX_LEVELS, levels, e);
}

int mesh_subdivide_object(mesh *m, size_t v0, size_t t0, int levels, const char *where, vx_err *e)
{
    if (mesh_subdivide(m, v0, t0, levels, e))
        return vx_wrap(e, "%s.subdivide", where);
    return 0;
}
