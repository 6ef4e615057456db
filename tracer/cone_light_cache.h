/* The cone marcher's light cache: the light cones' transmittance per cell of the element's
 * (integer) MIP level, shared by every cone element that enters the same cell.
 *
 * Why: about half of a shadowed Heitz–Neyret render went into light cones, one per contributing
 * element and light, and neighbouring pixels' elements cast nearly the same cone. A cached value is
 * the transmittance of a canonical light cone (from the cell's centre, the cell's own width; see
 * render_cone.c), so it depends only on the cell and never on the ray that happened to compute it:
 * the image is the same for any thread count.
 *
 * The cells are those around surfaces at any level, most of them empty in the sparse grid (an
 * element enters the surface from outside), so they have no dense index: an open-addressing hash
 * table keyed by (level, x, y, z), filled lock-free. A slot is claimed by a compare-and-swap on
 * its key and published by its state (0 empty, 1 being computed, 2 ready), as render.c's shading
 * cache: a thread that finds a slot being computed computes the value itself (the same numbers).
 * A full table (or a long probe) just means no caching for that cell. */
#ifndef VX_CONE_LIGHT_CACHE_H
#define VX_CONE_LIGHT_CACHE_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

typedef struct {
    _Atomic uint64_t *keys; /* 0: free; else the cell's key + 1 */
    atomic_int *state;      /* per slot: 0 empty, 1 being computed, 2 ready */
    float *T;               /* per slot: `lights` transmittances */
    size_t mask;            /* slots - 1 (a power of two) */
    int lights;
} cone_light_cache;

/* Room for about `cells` cells (the table gets twice that, a power of two, capped). Returns 0, or
 * -1 when out of memory (c is then zeroed). */
int cone_light_cache_init(cone_light_cache *c, size_t cells, int lights);
void cone_light_cache_free(cone_light_cache *c);

/* The key of cell (x, y, z) of `level` (x, y, z < 2^20, level < 16). */
static inline uint64_t cone_light_cache_key(int level, int x, int y, int z)
{
    return ((uint64_t)level << 60) | ((uint64_t)(uint32_t)x << 40) | ((uint64_t)(uint32_t)y << 20) | (uint64_t)(uint32_t)z;
}

/* The slot of `key`, claimed for it when it was free; -1 when the table has no room near it. */
long cone_light_cache_slot(cone_light_cache *c, uint64_t key);

/* Copies the slot's transmittances into T and returns 1 when they are ready, else 0. */
int cone_light_cache_get(const cone_light_cache *c, long slot, float *T);

/* Publishes T for the slot, unless another thread is already doing so (same values). */
void cone_light_cache_put(cone_light_cache *c, long slot, const float *T);

#endif
