/* The render's memory and threads (issue 15): the caches that the render threads write are
 * allocated and touched before the threads start, so the timed render takes (almost) no page
 * faults; and the image is bit-identical whatever the thread count.
 *  - vx_alloc_touched (tracer/core/prefault.h): every page resident when it returns (mincore), with
 *    the requested bytes; calloc's block of the same size is checked not to be, so that this test
 *    can tell the difference (GCC folds malloc + memset(0) into calloc: the bug this guards).
 *    vx_populate: a fresh block resident after it, and written afterwards without page faults.
 *  - city 128^3 with shadows, 128x128: binary (the voxel marcher's shading cache and, binary's
 *    opacity being direction-free, no memo) and heitz-neyret (the cone marcher's light cache):
 *    page faults inside the render's clock (render_counts.page_faults, the whole process) below a
 *    bound far under the caches' page count, and 1- and 2-thread images equal word for word. */
#include <stdint.h>
#include <stdio.h>
#include <malloc.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include "bake.h"
#include "prefault.h"
#include "render.h"
#include "unit.h"

/* Pages of [p, p + bytes) resident now (whole pages inside the block only). */
static size_t resident_pages(void *p, size_t bytes, size_t *pages)
{
    size_t ps = (size_t)sysconf(_SC_PAGESIZE);
    uintptr_t lo = ((uintptr_t)p + ps - 1) & ~(uintptr_t)(ps - 1), hi = ((uintptr_t)p + bytes) & ~(uintptr_t)(ps - 1);
    *pages = hi > lo ? (hi - lo) / ps : 0;
    if (!*pages)
        return 0;
    unsigned char *v = malloc(*pages);
    if (!v || mincore((void *)lo, hi - lo, v)) {
        free(v);
        return 0;
    }
    size_t n = 0;
    for (size_t i = 0; i < *pages; i++)
        n += v[i] & 1;
    free(v);
    return n;
}

/* Writes one byte a page of the block (a pattern of the page number); the page faults it took. */
static long write_pages(unsigned char *p, size_t bytes)
{
    struct rusage r0, r1;
    getrusage(RUSAGE_SELF, &r0);
    for (size_t i = 0; p && i < bytes; i += 4096)
        p[i] = (unsigned char)(i >> 12);
    getrusage(RUSAGE_SELF, &r1);
    return (r1.ru_minflt - r0.ru_minflt) + (r1.ru_majflt - r0.ru_majflt);
}

static void prefault_checks(void)
{
    const size_t bytes = (size_t)48 << 20; /* above malloc's mmap threshold: fresh pages */
    size_t pages;
    unsigned char *a = vx_alloc_touched(bytes, 0);
    size_t res = a ? resident_pages(a, bytes, &pages) : 0;
    CHECK("vx_alloc_touched: every page resident", a && pages > 0 && res == pages);
    int zero = a != NULL;
    for (size_t i = 0; a && i < bytes; i += 4093)
        zero &= a[i] == 0;
    CHECK("vx_alloc_touched: zero-filled", zero && a[bytes - 1] == 0);
    free(a);
    unsigned char *b = vx_alloc_touched(bytes, 0xFF);
    CHECK("vx_alloc_touched: filled with the byte asked", b && b[0] == 0xFF && b[bytes / 2] == 0xFF && b[bytes - 1] == 0xFF);
    free(b);
    /* The contrast: calloc's block is not resident, so the check above can fail. */
    void *c = calloc(bytes, 1);
    res = c ? resident_pages(c, bytes, &pages) : 0;
    CHECK("calloc's block is not resident (the check can fail)", c && res < pages / 2);
    free(c);
    void *one = vx_alloc_touched(0, 0);
    CHECK("vx_alloc_touched(0) gives a block to free", one != NULL);
    free(one);

    /* vx_populate: a fresh block's pages mapped by one call, whatever its alignment, so that the
     * writes after it (read() filling a .vox's records) take no page faults; contents untouched. */
    unsigned char *d = malloc(bytes);
    res = d ? resident_pages(d, bytes, &pages) : 0;
    int fresh = d && res < pages / 2;
    vx_populate(d, bytes);
    res = d ? resident_pages(d, bytes, &pages) : 0;
    CHECK("vx_populate: a fresh block's pages are all resident after it", fresh && pages > 0 && res == pages);
    /* Against the same writes to a block of the same size left to fault in (under AddressSanitizer
     * both also fault in the shadow memory, hence a ratio rather than zero). */
    unsigned char *plain = malloc(bytes);
    long faults = write_pages(d, bytes), plain_faults = write_pages(plain, bytes);
    CHECK("vx_populate: writing the block afterwards takes far fewer page faults than a plain block",
          d && plain && faults * 4 < plain_faults);
    printf("# vx_populate: %ld page faults writing %zu pages after it, %ld without it\n", faults, pages, plain_faults);
    free(plain);
    int kept = d != NULL;
    vx_populate(d + 1, bytes - 3); /* unaligned both ends, already resident: a no-op on the contents */
    for (size_t i = 0; d && i < bytes; i += 4096)
        kept &= d[i] == (unsigned char)(i >> 12);
    CHECK("vx_populate: contents unchanged", kept);
    free(d);
    vx_populate(NULL, bytes);
    unsigned char small[64] = {7};
    vx_populate(small, sizeof small);
    CHECK("vx_populate: NULL and small blocks are left alone", small[0] == 7);
}

static int render(const scene *s, const voxel_grid *g, const vx_model *m, const void *rec, int threads, image *img,
                  render_counts *c)
{
    render_options o;
    render_default_options(&o);
    o.width = o.height = 128;
    o.threads = threads;
    o.progress = 0;
    vx_err e;
    /* Freed memory back to the system first: a block reused from an earlier render is resident
     * already and would hide a cache that is not touched before the clock. */
    malloc_trim(0);
    if (render_image(s, g, m, rec, &o, img, c, &e)) {
        printf("not ok render %s: %s\n", m->name, e.msg);
        unit_failures++;
        return -1;
    }
    return 0;
}

static void render_checks(const scene *s, const char *model)
{
    const vx_model *m = model_find(model);
    char name[200];
    if (!m) {
        printf("not ok %s: no such model\n", model);
        unit_failures++;
        return;
    }
    bake_options bo = {.rays = 32, .seed = 1, .threads = 0, .progress = 0};
    bake_counts bc;
    double gs;
    voxel_grid g;
    void *rec = NULL;
    vx_err e;
    if (bake_scene(s, m, 128, &bo, &g, &rec, &bc, &gs, &e)) {
        printf("not ok %s: bake: %s\n", model, e.msg);
        unit_failures++;
        return;
    }
    image one, two;
    render_counts c1, c2;
    if (render(s, &g, m, rec, 1, &one, &c1) == 0) {
        if (render(s, &g, m, rec, 2, &two, &c2) == 0) {
            snprintf(name, sizeof name, "%s: 1- and 2-thread images bit-identical", model);
            CHECK(name, memcmp(one.data, two.data, (size_t)128 * 128 * 3 * sizeof(float)) == 0);
            /* The voxel marcher's shading cache alone is grid_count * 20 B (~2 MB, ~500 pages at
             * 128^3 city); thread start-up (stacks, TLS) costs a few dozen faults per thread. */
            size_t cache_pages = grid_count(&g, 0) * 20 / 4096;
            snprintf(name, sizeof name, "%s: page faults inside the timed render (%ld and %ld) < 200 (cache: %zu pages)",
                     model, c1.page_faults, c2.page_faults, cache_pages);
#ifdef __SANITIZE_ADDRESS__
            /* Under ASan the render threads fault in the sanitizer's own shadow and fake stacks: the
             * count says nothing about the caches. */
            CHECK(name, c1.page_faults >= 0 && c2.page_faults >= 0);
#else
            CHECK(name, c1.page_faults < 200 && c2.page_faults < 200);
#endif
            image_free(&two);
        }
        image_free(&one);
    }
    free(rec);
    grid_free(&g);
}

int main(void)
{
    prefault_checks();
    scene s;
    vx_err e;
    const char *path = "scenes/city.json";
    if (scene_load(path, &s, &e)) {
        printf("not ok city: %s\n", e.msg);
        return 1;
    }
    render_checks(&s, "binary");
    render_checks(&s, "heitz-neyret");
    render_checks(&s, "vmesh");
    scene_free(&s);
    return unit_exit();
}
