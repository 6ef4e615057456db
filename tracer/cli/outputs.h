/* The files one command reads and writes, gathered before any work so that an output naming an
 * input (the scene file, a mesh or texture it loads, --vox, compare's images) or another output is
 * refused at once, instead of being found out by a destroyed input and an exit status of 0. */
#ifndef VX_OUTPUTS_H
#define VX_OUTPUTS_H

#include <stddef.h>

#include "error.h"
#include "frames.h"
#include "scene.h"

typedef struct {
    char *what; /* an output's option ("-o", "--stats"), or an input's noun ("the scene file") */
    char *path;
    int output;
} outputs_file;

typedef struct {
    outputs_file *f;
    size_t count;
    int oom; /* an add ran out of memory: outputs_check fails */
} outputs_list;

void outputs_add(outputs_list *l, const char *what, const char *path, int output);
/* The scene file and every file its load read (scene.inputs). */
void outputs_add_scene(outputs_list *l, const scene *s);
/* -o and --stats, or with --frames A:B every numbered output of the sequence. */
void outputs_add_frames(outputs_list *l, const char *out_path, const char *stats_path, const frame_range *fr);
/* Fails when an output is the same file as an input or as another output: device and inode for a
 * file that exists, its directory's and its name for one that does not yet. */
int outputs_check(const outputs_list *l, vx_err *e);
void outputs_free(outputs_list *l);

/* truth's and render's check: the scene's files and --vox (or NULL) against the outputs. */
int outputs_check_scene(const scene *s, const char *vox, const char *out_path, const char *stats_path,
                        const frame_range *fr, vx_err *e);

#endif
