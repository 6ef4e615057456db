/* The list of procedural generators that scene files can name. A new generator is one more file in
 * scenes/generators/ plus one line here. */
#include <string.h>

#include "generator.h"

/* Each defined in its own file. */
extern const scene_generator generator_spheres;
extern const scene_generator generator_trees;
extern const scene_generator generator_tree;
extern const scene_generator generator_island;
extern const scene_generator generator_city;
extern const scene_generator generator_heightfield;

static const scene_generator *const all_generators[] = {
    &generator_spheres, &generator_trees, &generator_tree, &generator_island, &generator_city, &generator_heightfield, NULL,
};

const scene_generator *const *generator_all(void) { return all_generators; }

const scene_generator *generator_find(const char *name)
{
    if (!name)
        return NULL;
    for (const scene_generator *const *g = all_generators; *g; g++)
        if (strcmp((*g)->name, name) == 0)
            return *g;
    return NULL;
}
