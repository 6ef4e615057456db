/* The cone marcher's light cache: the light cones' transmittance per cell of the element's
 * (integer) MIP level, shared by every cone element that enters the same cell.
 *
 * Why: about half of a shadowed Heitz–Neyret render went into light cones, one per contributing
 * element and light, and neighbouring pixels' elements cast nearly the same cone. A cached value is
 * the transmittance of a canonical light cone (from the cell's centre, the cell's own width; see
 * render_cone_core.h), so it depends only on the cell and never on the ray that happened to
 * compute it: the image is the same for any thread count (and on either backend).
 *
 * The cells are those around surfaces at any level, most of them empty in the sparse grid (an
 * element enters the surface from outside), so they have no dense index: an open-addressing hash
 * table keyed by (level, x, y, z), filled lock-free. A slot is claimed by a compare-and-swap on
 * its key and published by its state (0 empty, 1 being computed, 2 ready), as render_voxel.c's shading
 * cache: a thread that finds a slot being computed computes the value itself (the same numbers).
 * A full table (or a long probe) just means no caching for that cell.
 *
 * The lookups are portable C (the OpenCL cone kernel runs them on buffers, with OpenCL's atomics
 * and cl_khr_int64_base_atomics for the keys); allocating is host code (cone_light_cache.c). */
#ifndef VX_CONE_LIGHT_CACHE_H
#define VX_CONE_LIGHT_CACHE_H

#include "grid_core.h"

#define LIGHT_CACHE_PROBES 32 /* beyond this the cell goes uncached */

#ifdef __OPENCL_VERSION__
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
typedef volatile __global ulong lc_key_t;
typedef volatile __global int lc_state_t;
typedef volatile __global float lc_value_t;
/* The key's compare-and-swap (returns the old key), the state's, a load that sees a published
 * state, and the publication (the values before the state). */
VX_INLINE uint64_t lc_cas_key(lc_key_t *p, uint64_t expected, uint64_t desired)
{
    return atom_cmpxchg(p, expected, desired);
}
VX_INLINE int lc_cas_state(lc_state_t *p, int expected, int desired) { return atomic_cmpxchg(p, expected, desired); }
VX_INLINE uint64_t lc_load_key(lc_key_t *p) { return *p; }
VX_INLINE int lc_load_state(lc_state_t *p) { return *p; }
VX_INLINE void lc_publish(lc_state_t *p)
{
    mem_fence(CLK_GLOBAL_MEM_FENCE);
    atomic_xchg(p, 2);
}
#else
#include <stddef.h>
#include <stdint.h>
typedef uint64_t lc_key_t;
typedef int lc_state_t;
typedef float lc_value_t;
static inline uint64_t lc_cas_key(lc_key_t *p, uint64_t expected, uint64_t desired)
{
    __atomic_compare_exchange_n(p, &expected, desired, 0, __ATOMIC_SEQ_CST, __ATOMIC_SEQ_CST);
    return expected;
}
static inline int lc_cas_state(lc_state_t *p, int expected, int desired)
{
    __atomic_compare_exchange_n(p, &expected, desired, 0, __ATOMIC_SEQ_CST, __ATOMIC_SEQ_CST);
    return expected;
}
static inline uint64_t lc_load_key(lc_key_t *p) { return __atomic_load_n(p, __ATOMIC_RELAXED); }
static inline int lc_load_state(lc_state_t *p) { return __atomic_load_n(p, __ATOMIC_ACQUIRE); }
static inline void lc_publish(lc_state_t *p) { __atomic_store_n(p, 2, __ATOMIC_RELEASE); }
#endif

typedef struct {
    lc_key_t *keys;     /* 0: free; else the cell's key + 1 */
    lc_state_t *state;  /* per slot: 0 empty, 1 being computed, 2 ready */
    lc_value_t *T;      /* per slot: `lights` transmittances */
    uint64_t mask;      /* slots - 1 (a power of two) */
    int lights;
} cone_light_cache;

/* The key of cell (x, y, z) of `level` (x, y, z < 2^20, level < 16). */
VX_INLINE uint64_t cone_light_cache_key(int level, int x, int y, int z)
{
    return ((uint64_t)level << 60) | ((uint64_t)(uint32_t)x << 40) | ((uint64_t)(uint32_t)y << 20) | (uint64_t)(uint32_t)z;
}

/* A 64-bit mix (splitmix64's finaliser): neighbouring cells must not crowd one run of slots. */
VX_INLINE uint64_t cone_light_cache_hash(uint64_t k)
{
    k ^= k >> 30;
    k *= (uint64_t)0xbf58476d1ce4e5b9UL;
    k ^= k >> 27;
    k *= (uint64_t)0x94d049bb133111ebUL;
    k ^= k >> 31;
    return k;
}

/* The slot of `key`, claimed for it when it was free; -1 when the table has no room near it. */
VX_INLINE long cone_light_cache_slot(const cone_light_cache *c, uint64_t key)
{
    if (!c->keys)
        return -1;
    uint64_t want = key + 1, h = cone_light_cache_hash(key);
    for (int probe = 0; probe < LIGHT_CACHE_PROBES; probe++) {
        uint64_t i = (h + (uint64_t)probe) & c->mask;
        uint64_t k = lc_load_key(&c->keys[i]);
        if (k == 0)
            k = lc_cas_key(&c->keys[i], 0, want); /* 0 when we claimed it, else who did */
        if (k == 0 || k == want)
            return (long)i;
    }
    return -1;
}

/* Copies the slot's transmittances into T and returns 1 when they are ready, else 0. */
VX_INLINE int cone_light_cache_get(const cone_light_cache *c, long slot, float *T)
{
    if (slot < 0 || lc_load_state(&c->state[slot]) != 2)
        return 0;
    for (int i = 0; i < c->lights; i++)
        T[i] = c->T[(size_t)slot * (size_t)c->lights + (size_t)i];
    return 1;
}

/* Publishes T for the slot, unless another thread is already doing so (same values). */
VX_INLINE void cone_light_cache_put(const cone_light_cache *c, long slot, const float *T)
{
    if (slot < 0 || lc_cas_state(&c->state[slot], 0, 1) != 0)
        return;
    for (int i = 0; i < c->lights; i++)
        c->T[(size_t)slot * (size_t)c->lights + (size_t)i] = T[i];
    lc_publish(&c->state[slot]);
}

#ifndef __OPENCL_VERSION__
/* Room for about `cells` cells (the table gets twice that, a power of two, capped). Returns 0, or
 * -1 when out of memory (c is then zeroed). */
int cone_light_cache_init(cone_light_cache *c, size_t cells, int lights);
/* The cells to make room for: the cells that light cones are cast from are those where camera
 * cones meet a surface, about one or two per pixel and never more than level 0's cells (coarser
 * levels add a fraction). Sized by the grid alone, bunny at 256^3 got millions of slots for the
 * ~16 k cells its 256^2 image used (tens of MB for nothing); a cell that finds the table full is
 * computed uncached, with the same value, so the size never changes an image. */
size_t cone_light_cache_cells(size_t level0_cells, size_t pixels);
/* The table's slots for about `cells` cells (what cone_light_cache_init allocates; the OpenCL
 * backend sizes its buffers alike). */
size_t cone_light_cache_slots(size_t cells);
/* The bytes an initialised table holds (keys, states, transmittances). */
size_t cone_light_cache_bytes(const cone_light_cache *c);
void cone_light_cache_free(cone_light_cache *c);
#endif

#endif
