/* Cone marching for models that declare VX_MARCH_CONE (Heitz & Neyret 2012). Not implemented yet:
 * such a model is refused by render_image before any ray is traced. */
#include "render_internal.h"

vec3 cone_trace_ray(const render_job *j, vec3 org, vec3 dir, thread_counts *tc)
{
    (void)org;
    (void)dir;
    (void)tc;
    return j->s->background;
}
