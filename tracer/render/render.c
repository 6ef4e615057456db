/* The C backend's render driver: the options' defaults, the threads (bands of image rows, as
 * parallel_for hands them out), the counters; the marching itself is the model's protocol's
 * marcher (render_voxel.c or render_cone.c). */
#include "render.h"

#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "prefault.h"
#include "render_internal.h"

/* The scene reader refuses more lights than the tracers' fixed per-voxel arrays hold. */
_Static_assert(VX_MAX_LIGHTS >= LIGHT_MAX_COUNT, "a scene's lights must fit the tracers' light arrays");

void render_default_options(render_options *o)
{
    memset(o, 0, sizeof *o);
    o->spp = 4;
    o->seed = 1;
    o->progress = 1;
    o->cache = 1;
    o->shadow_skip = 1;
    o->stop_opacity = 1.0f - 0.001f;
    o->shadow_method = -1;
    o->empty_skip = 1;
    o->shadow_clip = 1;
    o->pixel_bounds = 1;
    o->view_tiles = 1;
}

/* The threads take the image in bands of this many rows, not row by row. Neighbouring rows see
 * mostly the same voxels: when two threads render them at the same time, the shading cache's slots
 * that one thread writes are read by the other a moment later, and the cache lines bounce between
 * the cores (binary on city 256^3, 256x256: 1.68x from a second thread with single rows, 1.87x with
 * bands of 8, and the 2-thread frame 10 % shorter; the last rows go in smaller pieces, below). */
#define RENDER_BAND_ROWS 8
/* The image's last rows (a band's worth per thread) are handed out in pieces of this many rows:
 * the thread that took the last whole band made the others wait for it, up to a band (bunny 256^3,
 * binary, 2 threads: 0.1 to 0.5 ms of a 13-14 ms frame; with the pieces 0.03 to 0.1 ms). */
#define RENDER_TAIL_ROWS 2

typedef struct {
    render_job *j;
    void (*row)(void *job, int64_t row, int thread);
    int height;
    int head_bands; /* items 0 .. head_bands - 1: bands of RENDER_BAND_ROWS rows; then tail pieces */
} band_job;

/* The bands for `height` rows and `threads` threads: how many whole bands come first, and the
 * number of items in all. */
static int64_t render_band_items(int height, int threads, int *head_bands)
{
    int tail = threads * RENDER_BAND_ROWS < height ? threads * RENDER_BAND_ROWS : height;
    *head_bands = (height - tail) / RENDER_BAND_ROWS;
    int tail_rows = height - *head_bands * RENDER_BAND_ROWS;
    return *head_bands + (tail_rows + RENDER_TAIL_ROWS - 1) / RENDER_TAIL_ROWS;
}

static void render_band(void *p, int64_t item, int thread)
{
    const band_job *b = p;
    int64_t first = item < b->head_bands ? item * RENDER_BAND_ROWS
                                         : (int64_t)b->head_bands * RENDER_BAND_ROWS +
                                               (item - b->head_bands) * RENDER_TAIL_ROWS;
    int64_t rows = item < b->head_bands ? RENDER_BAND_ROWS : RENDER_TAIL_ROWS;
    for (int64_t r = first; r < first + rows && r < b->height; r++)
        b->row(b->j, r, thread);
}

int render_shadow_method_refused(const scene *s, const vx_model *m, const render_options *o, vx_err *e)
{
    shadow_request r = {o->shadow_method, o->shadow_res, o->threads, NULL};
    if (m->cone && shadow_effective_method(s, &r) == SHADOW_VOXEL)
        return vx_fail(e, "--shadows voxel: %s marches cones, whose elements are not voxels (no per-voxel shadow to "
                          "precompute): use march or slicemap-model",
                       m->name);
    return 0;
}

int render_image(const scene *s, const voxel_grid *g, const vx_model *m, const void *records,
                 const render_options *o, image *out, render_counts *counts, vx_err *e)
{
    if (o->spp < 1)
        return vx_fail(e, "--spp %d: expected at least 1 ray per pixel", o->spp);
    const render_marcher *marcher = m->cone ? &render_cone_marcher : &render_voxel_marcher;
    if (image_alloc(out, o->width, o->height, 3, e))
        return -1;
    int threads = parallel_threads(o->threads);
    /* Before any of this render's clocks (the precomputed shadows', the frame's): parallel.h. */
    parallel_prestart(threads);
    /* The precomputed shadows (when the method asks for them), built or taken from the cache before
     * the render's clock starts: their time is reported apart (counts->shadows). */
    shadow_request sr = {o->shadow_method, o->shadow_res, o->threads, slicemap_fill_model};
    const shadow_set *maps = NULL;
    shadow_stats sst;
    if (render_shadow_method_refused(s, m, o, e)) {
        image_free(out);
        return -1;
    }
    if (shadow_prepare(s, g, m, records, &sr, &maps, &sst, e)) {
        image_free(out);
        return -1;
    }
    double p0 = now_seconds();
    render_job j = {s, g, m, records, o, out, calloc((size_t)threads, sizeof(thread_counts)),
                    camera_pixel_spread(&s->camera, o->height), NULL, maps, 0, 0, sst.method, 0.0, 0};
    if (!j.tc || marcher->prepare(&j, e)) {
        if (!j.tc)
            vx_fail(e, "out of memory for the render");
        else
            marcher->release(&j);
        free(j.tc);
        image_free(out);
        shadow_release(maps);
        return -1;
    }
    long f0 = vx_minor_faults();
    double t0 = now_seconds(), setup = t0 - p0 - j.shadow_build_seconds; /* the precomputation apart */
    if (marcher->begin)
        marcher->begin(&j, threads);
    band_job bands = {&j, marcher->row, o->height, 0};
    parallel_for(render_band_items(o->height, threads, &bands.head_bands), threads, render_band, &bands,
                 o->progress ? "render" : NULL);
    double t1 = now_seconds();
    memset(counts, 0, sizeof *counts);
    counts->seconds = t1 - t0;
    counts->setup_seconds = setup;
    counts->page_faults = vx_minor_faults() - f0;
    counts->shadows = sst;
    if (sst.method == SHADOW_VOXEL) {
        counts->shadows.build_seconds = j.shadow_build_seconds;
        counts->shadows.bytes = j.shadow_bytes;
    }
    counts->cache_bytes = j.cache_bytes;
    counts->map_bytes = j.map_bytes;
    uint64_t model_cycles = 0, total_cycles = 0;
    for (int t = 0; t < threads; t++) {
        counts->rays += j.tc[t].rays;
        counts->shadow_rays += j.tc[t].shadow_rays;
        counts->voxel_visits += j.tc[t].voxel_visits;
        counts->model_evals += j.tc[t].model_evals;
        counts->cache_hits += j.tc[t].cache_hits;
        counts->memo_hits += j.tc[t].memo_hits;
        counts->shadows.queries += j.tc[t].shadow_queries;
        model_cycles += j.tc[t].model_cycles;
        total_cycles += j.tc[t].total_cycles;
    }
    double frac = total_cycles ? (double)model_cycles / (double)total_cycles : 0.0;
    counts->model_seconds = counts->seconds * frac;
    counts->traversal_seconds = counts->seconds - counts->model_seconds;
    free(j.tc);
    marcher->release(&j);
    shadow_release(maps);
    return 0;
}
