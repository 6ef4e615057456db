/* `voxlab render` for animated scenes (--frame, --frames, --filter; issue 17): per frame, the voxel
 * grid from a re-bake of the posed scene or from the moving objects' transformed records
 * (tracer/dynamic/), rendered and written like a still. */
#ifndef VX_RENDER_FRAMES_H
#define VX_RENDER_FRAMES_H

#include "backend.h"
#include "bake.h"
#include "frames.h"
#include "render.h"

int render_frames(scene *s, const vx_model *m, int res, const bake_options *bo, const render_options *o,
                  const vx_backend *backend, const char *out_path, const char *stats_path, const frame_range *fr,
                  int filter, int argc, char **argv, vx_err *e);

#endif
