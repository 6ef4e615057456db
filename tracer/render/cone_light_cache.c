/* The cone marcher's light cache: allocation (the lookups are portable, in cone_light_cache.h). */
#include "cone_light_cache.h"

#include <stdlib.h>
#include <string.h>

#include "prefault.h"

#define LIGHT_CACHE_MAX_SLOTS ((size_t)1 << 23) /* 8 M slots: 64 MB of keys at most */

size_t cone_light_cache_slots(size_t cells)
{
    size_t slots = 1024;
    while (slots < 2 * cells && slots < LIGHT_CACHE_MAX_SLOTS)
        slots *= 2;
    return slots;
}

/* Transmittances a slot holds: one a light (one even without lights, so the block is never empty). */
static size_t values_per_slot(int lights) { return (size_t)(lights > 0 ? lights : 1); }

size_t cone_light_cache_cells(size_t level0_cells, size_t pixels)
{
    size_t per_pixels = 2 * pixels;
    return per_pixels < level0_cells ? per_pixels : level0_cells;
}

int cone_light_cache_init(cone_light_cache *c, size_t cells, int lights)
{
    memset(c, 0, sizeof *c);
    size_t slots = cone_light_cache_slots(cells);
    /* Touched here, before the render threads start (prefault.h: calloc's pages would fault inside
     * the render's clock). Zero keys and states: every slot free and empty. */
    c->keys = vx_alloc_touched(slots * sizeof *c->keys, 0);
    c->state = vx_alloc_touched(slots * sizeof *c->state, 0);
    c->T = vx_alloc_touched(slots * values_per_slot(lights) * sizeof *c->T, 0);
    if (!c->keys || !c->state || !c->T) {
        cone_light_cache_free(c);
        return -1;
    }
    c->mask = slots - 1;
    c->lights = lights;
    return 0;
}

size_t cone_light_cache_bytes(const cone_light_cache *c)
{
    if (!c->keys)
        return 0;
    size_t slots = (size_t)c->mask + 1;
    return slots * (sizeof *c->keys + sizeof *c->state + values_per_slot(c->lights) * sizeof *c->T);
}

void cone_light_cache_free(cone_light_cache *c)
{
    free(c->keys);
    free(c->state);
    free(c->T);
    memset(c, 0, sizeof *c);
}
