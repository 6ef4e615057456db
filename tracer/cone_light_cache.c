/* The cone marcher's light cache (see cone_light_cache.h). */
#include "cone_light_cache.h"

#include <stdlib.h>
#include <string.h>

#define LIGHT_CACHE_MAX_SLOTS ((size_t)1 << 23) /* 8 M slots: 64 MB of keys at most */
#define LIGHT_CACHE_PROBES 32                   /* beyond this the cell goes uncached */

int cone_light_cache_init(cone_light_cache *c, size_t cells, int lights)
{
    memset(c, 0, sizeof *c);
    size_t slots = 1024;
    while (slots < 2 * cells && slots < LIGHT_CACHE_MAX_SLOTS)
        slots *= 2;
    c->keys = calloc(slots, sizeof *c->keys);
    c->state = calloc(slots, sizeof *c->state);
    c->T = calloc(slots * (size_t)(lights > 0 ? lights : 1), sizeof *c->T);
    if (!c->keys || !c->state || !c->T) {
        cone_light_cache_free(c);
        return -1;
    }
    c->mask = slots - 1;
    c->lights = lights;
    return 0;
}

void cone_light_cache_free(cone_light_cache *c)
{
    free(c->keys);
    free(c->state);
    free(c->T);
    memset(c, 0, sizeof *c);
}

/* A 64-bit mix (splitmix64's finaliser): neighbouring cells must not crowd one run of slots. */
static size_t hash_key(uint64_t k)
{
    k ^= k >> 30;
    k *= UINT64_C(0xbf58476d1ce4e5b9);
    k ^= k >> 27;
    k *= UINT64_C(0x94d049bb133111eb);
    k ^= k >> 31;
    return (size_t)k;
}

long cone_light_cache_slot(cone_light_cache *c, uint64_t key)
{
    if (!c->keys)
        return -1;
    uint64_t want = key + 1;
    size_t h = hash_key(key);
    for (int probe = 0; probe < LIGHT_CACHE_PROBES; probe++) {
        size_t i = (h + (size_t)probe) & c->mask;
        uint64_t k = atomic_load_explicit(&c->keys[i], memory_order_relaxed);
        if (k == 0) {
            uint64_t expected = 0;
            if (atomic_compare_exchange_strong(&c->keys[i], &expected, want))
                return (long)i;
            k = expected; /* another thread claimed it meanwhile: for this cell? */
        }
        if (k == want)
            return (long)i;
    }
    return -1;
}

int cone_light_cache_get(const cone_light_cache *c, long slot, float *T)
{
    if (slot < 0 || atomic_load_explicit(&c->state[slot], memory_order_acquire) != 2)
        return 0;
    memcpy(T, &c->T[(size_t)slot * (size_t)c->lights], (size_t)c->lights * sizeof *T);
    return 1;
}

void cone_light_cache_put(cone_light_cache *c, long slot, const float *T)
{
    if (slot < 0)
        return;
    int expected = 0;
    if (!atomic_compare_exchange_strong(&c->state[slot], &expected, 1))
        return;
    memcpy(&c->T[(size_t)slot * (size_t)c->lights], T, (size_t)c->lights * sizeof *T);
    atomic_store_explicit(&c->state[slot], 2, memory_order_release);
}
