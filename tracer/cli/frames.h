/* Frames of an animated scene on the command line (issue 17): --frame F and --frames A:B parsed,
 * and the numbered file names of a sequence (out.exr -> out_0003.exr). */
#ifndef VX_FRAMES_H
#define VX_FRAMES_H

#include <stddef.h>

#include "scene.h"

typedef struct {
    int given;       /* --frame or --frames was given */
    int sequence;    /* --frames: numbered outputs */
    int first, last;
} frame_range;

/* Parses option `option` (--frame or --frames) of command cmd into r; errors on stderr, -1. */
int frames_parse(const char *cmd, const char *option, const char *text, frame_range *r);
/* Without --frame/--frames, the scene's first frame; then checks that the frames lie in the scene's
 * "frames" (before any work: a sequence's outputs are listed frame by frame). Leaves s posed at the
 * first frame. */
int frames_resolve(scene *s, frame_range *r, vx_err *e);
/* path with _NNNN (the frame, 4 digits at least) before its extension. */
void frames_path(const char *path, int frame, char *out, size_t size);

#endif
