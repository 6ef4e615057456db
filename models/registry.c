/* Every model voxlab knows, one line each. Adding a model = adding its file and one line here. */
#include <string.h>

#include "model.h"

extern const vx_model model_binary;
extern const vx_model model_alpha;
extern const vx_model model_heitz_neyret;
extern const vx_model model_vmesh;

static const vx_model *const models[] = {
    &model_binary,
    &model_alpha,
    &model_heitz_neyret,
    &model_vmesh,
    NULL,
};

const vx_model *const *model_all(void) { return models; }

const vx_model *model_find(const char *name)
{
    for (const vx_model *const *m = models; *m; m++)
        if (strcmp((*m)->name, name) == 0)
            return *m;
    return NULL;
}
