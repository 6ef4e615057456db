#include "estimate.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "grid.h"
#include "instancing.h"
#include "parallel.h"
#include "shading_cache.h"

/* Embree's BVH over triangles costs of the order of 100 bytes a triangle; with the mesh's own
 * arrays (positions, normals, uvs, colours, indices, materials) about 200 in all. */
static double mesh_bytes(const mesh *m) { return 200.0 * (double)m->triangle_count + 48.0 * (double)m->vertex_count; }

/* An instanced scene holds each prototype once and a placement (and Embree instance) per copy. */
static double scene_bytes(const scene *s)
{
    double b = mesh_bytes(&s->mesh);
    for (int q = 0; s->inst && q < s->inst->proto_count; q++)
        b += mesh_bytes(&s->inst->protos[q]);
    return b + (s->inst ? 400.0 * (double)s->inst->count : 0.0);
}

static double mesh_area(const mesh *m)
{
    double area = 0;
    for (size_t t = 0; t < m->triangle_count; t++) {
        const float *p[3];
        for (int k = 0; k < 3; k++)
            p[k] = &m->positions[3 * (size_t)m->indices[3 * t + (size_t)k]];
        double e1[3], e2[3];
        for (int a = 0; a < 3; a++) {
            e1[a] = p[1][a] - p[0][a];
            e2[a] = p[2][a] - p[0][a];
        }
        double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
               cz = e1[0] * e2[1] - e1[1] * e2[0];
        area += 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
    }
    return area;
}

/* Area of every instance copy: the prototype's, times the placement's area scale (|det|^(2/3),
 * exact for a uniform scale). */
static double copies_area(const scene *s)
{
    const scene_instancing *in = s->inst;
    if (!in)
        return 0;
    double *proto = calloc((size_t)in->proto_count + 1, sizeof *proto), area = 0;
    if (!proto)
        return 0;
    for (int q = 0; q < in->proto_count; q++)
        proto[q] = mesh_area(&in->protos[q]);
    for (size_t i = 0; i < in->count; i++) {
        vec3 k = in->inst[i].x.scale;
        area += proto[in->inst[i].proto] * pow(fabs((double)k.x * k.y * k.z), 2.0 / 3.0);
    }
    free(proto);
    return area;
}

/* Non-empty voxels at resolution res: the larger of two estimates, capped at res^3. Fine meshes:
 * the distinct cells holding a vertex (a hash set over the vertices). Coarse meshes: the surface's
 * area over a cell's face, times 1.5 (a plane crossing the grid at an angle meets up to sqrt(3) times
 * as many cells as its area in faces). Measured against the real grid on the shipped scenes at
 * 64^3 and 256^3, within a factor of about 2 either way. */
static double voxel_estimate(const scene *s, int res)
{
    vec3 lo = s->bounds_lo, hi = s->bounds_hi;
    double ext = vx_fmax(vx_fmax(hi.x - lo.x, hi.y - lo.y), hi.z - lo.z);
    if (!(ext > 0))
        return 1;
    double vs = ext / res, area = mesh_area(&s->mesh) + copies_area(s);
    const mesh *m = &s->mesh;
    double by_area = 1.5 * area / (vs * vs);
    /* Distinct vertex cells; without memory for the set, the vertex count bounds them. */
    double by_vertex = (double)m->vertex_count;
    size_t slots = 1024;
    while (slots < 2 * m->vertex_count)
        slots *= 2;
    uint64_t *set = calloc(slots, sizeof *set);
    if (set) {
        size_t distinct = 0;
        for (size_t v = 0; v < m->vertex_count; v++) {
            uint64_t key = 1; /* 0 marks an empty slot */
            for (int a = 0; a < 3; a++) {
                double c = floor((m->positions[3 * v + (size_t)a] - (&lo.x)[a]) / vs);
                key = key * 2048 + (uint64_t)vx_fmin(vx_fmax(c, 0), res - 1);
            }
            size_t h = (size_t)((key * 0x9e3779b97f4a7c15ULL) >> 20) & (slots - 1);
            while (set[h] && set[h] != key)
                h = (h + 1) & (slots - 1);
            if (!set[h]) {
                set[h] = key;
                distinct++;
            }
        }
        free(set);
        by_vertex = (double)distinct;
    }
    return vx_fmin(vx_fmax(by_area, by_vertex), (double)res * res * res);
}

static void finish(vx_estimate *e, int threads)
{
    e->total_bytes = e->scene_bytes + e->grid_bytes + e->record_bytes + e->work_bytes + e->image_bytes;
    e->seconds = e->rays / (ESTIMATE_RAYS_PER_CORE_SECOND * parallel_threads(threads));
}

static double shadow_lights(const scene *s) { return (s->effects & EFFECT_SHADOWS) ? s->light_count : 0; }

void estimate_truth(const scene *s, int width, int height, int spp, int threads, vx_estimate *out)
{
    memset(out, 0, sizeof *out);
    double px = (double)width * height;
    out->scene_bytes = scene_bytes(s);
    out->image_bytes = px * 4 * sizeof(float) + px * 4; /* RGBA floats, 8-bit PNG samples */
    out->rays = px * spp * (1 + shadow_lights(s));
    finish(out, threads);
}

/* The coarse levels' plain bits (grid_level.dense) of a res^3 grid, level by level as grid.h keeps them. */
static double coarse_bits_bytes(int res)
{
    double bytes = 0;
    for (int level = 1, n = (res + 1) / 2; n >= 1; level++, n = n > 1 ? (n + 1) / 2 : 0)
        bytes += (double)grid_dense_words(level, n) * sizeof(uint64_t);
    return bytes;
}

/* A voxel run with v level-0 voxels at res^3: dense_bits when the grid is voxelised here (a bake, or a
 * render that bakes), not when it is rebuilt from a .vox file's cells; records: their bytes. */
static void estimate_grid_run(const scene *s, int res, double v, int dense_bits, double records, int rays, int width,
                              int height, int spp, int cache, int threads, vx_estimate *out)
{
    memset(out, 0, sizeof *out);
    double n = res;
    out->voxels = v;
    out->scene_bytes = scene_bytes(s);
    /* The build's dense bits (n^3 bits, plus an eighth for the next level), or the cells read from a
     * .vox file (4 bytes a voxel); the columns of every level (n^2 words, plus a third for the coarser
     * ones), and per voxel its coordinates and bits. */
    out->grid_bytes = (dense_bits ? n * n * n / 8 * 1.15 : v * 4) + n * n * 8 * 1.34 + v * 1.15 * 8 +
                      coarse_bits_bytes(res);
    out->record_bytes = records;
    out->work_bytes = (double)parallel_threads(threads) * rays * sizeof(vx_sample);
    if (width > 0) {
        double px = (double)width * height;
        out->image_bytes = px * 4 * sizeof(float) + px * 4;
        if (cache) { /* the shading cache: sized by the image, at most one slot a voxel */
            size_t slots;
            int hash_bits;
            shading_cache_size((size_t)v, (size_t)px, 0, &slots, &hash_bits);
            out->work_bytes += (double)slots * sizeof(shading_cache_slot);
        }
        out->rays = px * spp * (1 + shadow_lights(s));
    }
    out->rays += v * rays; /* the bake (none when rendering a .vox) */
    finish(out, threads);
    /* A bake also costs per voxel, whatever its rays: its own triangles' list and the model's fit
     * (about 60 us of one core per voxel on the development machine). */
    if (rays > 0)
        out->seconds += v * ESTIMATE_BAKE_CORE_SECONDS_PER_VOXEL / parallel_threads(threads);
}

void estimate_voxels(const scene *s, const vx_model *m, int res, int rays, int width, int height, int spp,
                     int cache, int threads, vx_estimate *out)
{
    double v = voxel_estimate(s, res);
    estimate_grid_run(s, res, v, 1, v * (double)m->record.bytes * (m->record.levels ? 1.15 : 1.0), rays, width,
                      height, spp, cache, threads, out);
}

void estimate_vox(const scene *s, const voxfile_header *h, int width, int height, int spp, int cache, int threads,
                  vx_estimate *out)
{
    estimate_grid_run(s, h->n, (double)h->voxels, 0, (double)h->record_count * (double)h->voxel_bytes, 0, width,
                      height, spp, cache, threads, out);
}

double estimate_budget_bytes(void)
{
    double budget = INFINITY;
    FILE *f = fopen("/proc/meminfo", "r");
    if (f) {
        char line[256];
        unsigned long long kb;
        while (fgets(line, sizeof line, f))
            if (sscanf(line, "MemAvailable: %llu kB", &kb) == 1)
                budget = (double)kb * 1024.0;
        fclose(f);
    }
    struct rlimit rl;
    if (getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY)
        budget = vx_fmin(budget, (double)rl.rlim_cur);
    const char *env = getenv("VOXLAB_MEMORY_BUDGET");
    if (env && *env) {
        char *end;
        double b = strtod(env, &end);
        if (end != env && b > 0)
            budget = vx_fmin(budget, b);
    }
    return budget;
}

static double gib(double b) { return b / (1024.0 * 1024.0 * 1024.0); }

int estimate_check(const vx_estimate *est, vx_err *e)
{
    double budget = estimate_budget_bytes();
    if (est->total_bytes <= budget)
        return 0;
    return vx_fail(e, "needs about %.2f GiB of memory (scene %.2f, grid %.2f, records %.2f, work %.2f, image %.2f), "
                      "more than the %.2f GiB available: lower --res, --size or --rays (`--dry-run` shows the estimate)",
                   gib(est->total_bytes), gib(est->scene_bytes), gib(est->grid_bytes), gib(est->record_bytes),
                   gib(est->work_bytes), gib(est->image_bytes), gib(budget));
}

void estimate_print(FILE *f, const char *command, const vx_estimate *est)
{
    fprintf(f, "voxlab %s: dry run, nothing computed or written\n", command);
    if (est->voxels > 0)
        fprintf(f, "  voxels (estimate)  %.0f\n", est->voxels);
    fprintf(f, "  memory (estimate)  %.3f GiB: scene %.3f, grid %.3f, records %.3f, work %.3f, image %.3f\n",
            gib(est->total_bytes), gib(est->scene_bytes), gib(est->grid_bytes), gib(est->record_bytes),
            gib(est->work_bytes), gib(est->image_bytes));
    fprintf(f, "  available          %.3f GiB\n", gib(estimate_budget_bytes()));
    fprintf(f, "  rays               %.0f\n", est->rays);
    fprintf(f, "  time (estimate)    %.1f s (order of magnitude: %.0f rays/s per core; marching costs depend on "
               "the model)\n", est->seconds, ESTIMATE_RAYS_PER_CORE_SECOND);
}
