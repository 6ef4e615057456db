/* --frame / --frames parsing and numbered output names (frames.h). */
#include "frames.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "animation.h"
#include "fileio.h"
#include "cli.h"

int frames_parse(const char *cmd, const char *option, const char *text, frame_range *r)
{
    long long a, b;
    if (r->given) {
        fprintf(stderr, "voxlab %s: give one --frame or --frames\n", cmd);
        return -1;
    }
    if (strcmp(option, "--frame") == 0) {
        if (cli_int(cmd, option, text, 0, 1000000, &a))
            return -1;
        *r = (frame_range){1, 0, (int)a, (int)a};
        return 0;
    }
    const char *colon = strchr(text, ':');
    char head[32];
    if (!colon || (size_t)(colon - text) >= sizeof head) {
        fprintf(stderr, "voxlab %s: --frames %s: expected A:B (first and last frame, e.g. 0:47)\n", cmd, text);
        return -1;
    }
    memcpy(head, text, (size_t)(colon - text));
    head[colon - text] = 0;
    if (cli_int(cmd, option, head, 0, 1000000, &a) || cli_int(cmd, option, colon + 1, 0, 1000000, &b))
        return -1;
    if (b < a) {
        fprintf(stderr, "voxlab %s: --frames %s: the last frame comes before the first\n", cmd, text);
        return -1;
    }
    *r = (frame_range){1, 1, (int)a, (int)b};
    return 0;
}

void frames_path(const char *path, int frame, char *out, size_t size)
{
    const char *dot = fileio_extension(path);
    if (!*dot)
        dot = path + strlen(path);
    snprintf(out, size, "%.*s_%04d%s", (int)(dot - path), path, frame, dot);
}

int frames_resolve(scene *s, frame_range *r, vx_err *e)
{
    if (!r->given)
        r->first = r->last = s->anim ? s->anim->first : 0;
    return scene_set_frame(s, r->last, e) || scene_set_frame(s, r->first, e) ? -1 : 0;
}

int frames_check_shadows(scene *s, const frame_range *r, const shadow_request *sr, vx_err *e)
{
    if (!shadow_lights_depend_on_pose(s, sr))
        return 0;
    for (int f = r->first; f <= r->last; f++)
        if (scene_set_frame(s, f, e) || shadow_check_lights(s, sr, e))
            return r->given ? vx_wrap(e, "frame %d", f) : -1;
    return scene_set_frame(s, r->first, e);
}

void frames_remove(const char *out_path, const char *stats_path, int first, int end)
{
    for (int f = first; f < end; f++) {
        char path[4096];
        frames_path(out_path, f, path, sizeof path);
        remove(path);
        if (stats_path) {
            frames_path(stats_path, f, path, sizeof path);
            remove(path);
        }
    }
}
