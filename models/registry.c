/* Every model voxlab knows, one line each. Adding a model = adding its file and one line here. */
#include <pthread.h>
#include <string.h>

#include "model.h"

extern const vx_model model_binary;
extern const vx_model model_alpha;
extern const vx_model model_vmesh;
const vx_model *hn_model_checked(void); /* heitz-neyret with its record validator (hn_validate.c) */

static const vx_model *models[5];
static pthread_once_t once = PTHREAD_ONCE_INIT;

/* Filled at run time because one entry is built at run time (hn_model_checked). */
static void init(void)
{
    int i = 0;
    models[i++] = &model_binary;
    models[i++] = &model_alpha;
    models[i++] = hn_model_checked();
    models[i++] = &model_vmesh;
    models[i] = NULL;
}

const vx_model *const *model_all(void)
{
    pthread_once(&once, init);
    return models;
}

const vx_model *model_find(const char *name)
{
    for (const vx_model *const *m = model_all(); *m; m++)
        if (strcmp((*m)->name, name) == 0)
            return *m;
    return NULL;
}
