/* The voxlab subcommands (argv[0] is the subcommand's name; each returns the exit status). */
#ifndef VX_COMMANDS_H
#define VX_COMMANDS_H

#include "bake.h"
#include "cli.h"
#include "scene.h"
#include "voxfile.h"

int cmd_truth(int argc, char **argv);
int cmd_compare(int argc, char **argv);
int cmd_bake(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_models(int argc, char **argv);

/* The build's version: git describe of the tree it was built from (version.c). */
const char *voxlab_version(void);
/* The compiler and flags this binary was built with (`voxlab --version`'s second line). */
const char *voxlab_build(void);

/* The .vox header of a bake of s (cmd_bake.c): what `voxlab bake` and the Python API write. */
void bake_header_fill(voxfile_header *h, const scene *s, const vx_model *m, const bake_options *o,
                      const voxel_grid *g);
/* Each command's --help: synopsis, summary, options with defaults (in its cmd_*.c). */
extern const cli_command cmd_truth_help, cmd_compare_help, cmd_bake_help, cmd_render_help, cmd_models_help;

#endif
