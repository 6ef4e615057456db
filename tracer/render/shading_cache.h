/* The C backend's shading cache: each voxel's answer (radiance, opacity) for the direction
 * voxel -> camera, computed by the first ray that reaches the voxel and reused by the others.
 *
 * Sized by the image, not by the grid (issue 15): a render only ever needs the voxels that the rows
 * being rendered now share with their neighbours, so one slot a voxel (38 MB at 1024^3 for a 256^2
 * image, with 8 % hits) is memory for nothing. The table has SHADING_CACHE_SLOTS_PER_PIXEL slots a
 * pixel (a power of two), and one slot a voxel when the grid has fewer voxels than that (then a
 * voxel's slot is its own index and nothing is ever evicted). With fewer slots than voxels a voxel's
 * slot is a hash of its index and a newer voxel evicts an older one.
 *
 * Losing an answer is always safe: a cached answer depends only on the voxel, so whichever thread
 * computes it again writes the same bits, and the image never depends on what was evicted, on the
 * thread count or on the table's size (tests/unit_render.c renders city with a 16-slot table).
 *
 * A slot is a sequence lock (Boehm, "Can seqlocks get along with programming language memory
 * models?", 2012): its tag holds the voxel (index + 1, 0: none) in the high 32 bits and a counter in
 * the low 32 bits, odd while a writer fills the values. A reader accepts the values only when the
 * tag is that voxel's, even, and unchanged across the read; the counter makes a slot that went from
 * voxel A to B and back to A during a read count as changed, so values of two writes are never
 * mixed. The values are relaxed atomics, so the race with a writer is defined behaviour (and quiet
 * under ThreadSanitizer). A writer that finds the slot being written, or already holding its voxel,
 * leaves it. */
#ifndef VX_SHADING_CACHE_H
#define VX_SHADING_CACHE_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "vec.h"

/* Slots a pixel: measured on bunny, city and trees at 256^3 to 1024^3 (issue 15's note), enough that
 * the hit count stays within 1 % of one slot a voxel. */
#define SHADING_CACHE_SLOTS_PER_PIXEL 4
#define SHADING_CACHE_RUN_BITS 3 /* runs of 8 voxels kept together (see shading_cache_slot_of) */

typedef struct {
    _Atomic uint64_t tag;  /* (index + 1) << 32 | counter (odd: being written) */
    atomic_uint value[4];  /* radiance x, y, z, opacity: the floats' bits */
} shading_cache_slot;

typedef struct {
    shading_cache_slot *slots;
    size_t count;  /* slots */
    int hash_bits; /* 0: slot = voxel index (count >= voxels); else count = 2^hash_bits */
} shading_cache;

/* The table's size for `voxels` voxels and `pixels` pixels (slots 0: by the image). */
static inline void shading_cache_size(size_t voxels, size_t pixels, size_t slots, size_t *count, int *hash_bits)
{
    size_t want = slots ? slots : pixels * SHADING_CACHE_SLOTS_PER_PIXEL;
    /* hash_bits > SHADING_CACHE_RUN_BITS when hashed (0 means one slot a voxel) */
    size_t pow2 = (size_t)2 << SHADING_CACHE_RUN_BITS;
    int bits = SHADING_CACHE_RUN_BITS + 1;
    while (pow2 < want && bits < 40) {
        pow2 <<= 1;
        bits++;
    }
    if (voxels <= pow2) {
        *count = voxels ? voxels : 1;
        *hash_bits = 0;
    } else {
        *count = pow2;
        *hash_bits = bits;
    }
}

static inline shading_cache_slot *shading_cache_slot_of(const shading_cache *c, int64_t index)
{
    if (!c->hash_bits)
        return &c->slots[index];
    /* Runs of 2^SHADING_CACHE_RUN_BITS consecutive voxels (neighbours along z) stay side by side, as they
     * are in the records, and the runs are spread by Fibonacci hashing, so that the voxels a few rows
     * of pixels share rarely evict each other (hashing each voxel alone made 512^3 frames 5 % slower
     * than one slot a voxel: every lookup a cache miss). */
    uint64_t run = (uint64_t)index >> SHADING_CACHE_RUN_BITS;
    uint64_t h = (run * UINT64_C(0x9E3779B97F4A7C15)) >> (64 - (c->hash_bits - SHADING_CACHE_RUN_BITS));
    return &c->slots[h << SHADING_CACHE_RUN_BITS | ((uint64_t)index & ((1u << SHADING_CACHE_RUN_BITS) - 1u))];
}

/* 1 with voxel `index`'s answer in *radiance and *opacity when the slot holds it, else 0. */
static inline int shading_cache_get(const shading_cache *c, int64_t index, vec3 *radiance, float *opacity)
{
    shading_cache_slot *s = shading_cache_slot_of(c, index);
    uint64_t t = atomic_load_explicit(&s->tag, memory_order_acquire);
    if ((t & 1u) || (t >> 32) != (uint64_t)index + 1u)
        return 0;
    /* Four scalars, not an array: the array went through the stack as four 4-byte stores read back
     * by one 16-byte load, which stalls on store forwarding at every cache hit (5 % of an alpha
     * frame on one instruction). */
    unsigned v0 = atomic_load_explicit(&s->value[0], memory_order_relaxed);
    unsigned v1 = atomic_load_explicit(&s->value[1], memory_order_relaxed);
    unsigned v2 = atomic_load_explicit(&s->value[2], memory_order_relaxed);
    unsigned v3 = atomic_load_explicit(&s->value[3], memory_order_relaxed);
    /* With one slot a voxel (hash_bits 0) a slot is written once, by its own voxel, and never again
     * (a writer leaves a slot that holds its voxel): the tag seen above already covers the values. */
    if (c->hash_bits) {
        atomic_thread_fence(memory_order_acquire);
        if (atomic_load_explicit(&s->tag, memory_order_relaxed) != t)
            return 0; /* a writer came by during the read */
    }
    memcpy(&radiance->x, &v0, 4);
    memcpy(&radiance->y, &v1, 4);
    memcpy(&radiance->z, &v2, 4);
    memcpy(opacity, &v3, 4);
    return 1;
}

/* Stores voxel `index`'s answer in its slot, evicting whatever was there (see the top). */
static inline void shading_cache_put(const shading_cache *c, int64_t index, vec3 radiance, float opacity)
{
    shading_cache_slot *s = shading_cache_slot_of(c, index);
    uint64_t key = (uint64_t)index + 1u;
    uint64_t t = atomic_load_explicit(&s->tag, memory_order_relaxed);
    if ((t & 1u) || (t >> 32) == key)
        return;
    if (!atomic_compare_exchange_strong_explicit(&s->tag, &t, t + 1u, memory_order_relaxed, memory_order_relaxed))
        return; /* another writer won the slot */
    /* The odd tag before any value, as a reader that sees a new value will see it. */
    atomic_thread_fence(memory_order_release);
    unsigned v[4];
    memcpy(&v[0], &radiance.x, 4);
    memcpy(&v[1], &radiance.y, 4);
    memcpy(&v[2], &radiance.z, 4);
    memcpy(&v[3], &opacity, 4);
    for (int i = 0; i < 4; i++)
        atomic_store_explicit(&s->value[i], v[i], memory_order_relaxed);
    atomic_store_explicit(&s->tag, key << 32 | (uint32_t)(t + 2u), memory_order_release);
}

#endif
