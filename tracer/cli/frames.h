/* Frames of an animated scene on the command line (issue 17): --frame F and --frames A:B parsed,
 * and the numbered file names of a sequence (out.exr -> out_0003.exr). */
#ifndef VX_FRAMES_H
#define VX_FRAMES_H

#include <stddef.h>

#include "scene.h"
#include "shadow_set.h"

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
/* Before any work, what a frame's render would refuse (a point light inside the posed scene's
 * bounding sphere under slicemap shadows), at every frame of r: the message names the frame. Poses
 * s only when the shadows depend on it; leaves it at r's first frame. */
int frames_check_shadows(scene *s, const frame_range *r, const shadow_request *sr, vx_err *e);
/* Removes the numbered files of frames [first, end) of a sequence that failed at frame end: a
 * failed --frames run leaves none of its files. */
void frames_remove(const char *out_path, const char *stats_path, int first, int end);
/* path with _NNNN (the frame, 4 digits at least) before its extension. */
void frames_path(const char *path, int frame, char *out, size_t size);

#endif
