/* The voxlab subcommands (argv[0] is the subcommand's name; each returns the exit status). */
#ifndef VX_COMMANDS_H
#define VX_COMMANDS_H


int cmd_truth(int argc, char **argv);
int cmd_compare(int argc, char **argv);
int cmd_bake(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_models(int argc, char **argv);

/* The build's version: git describe of the tree it was built from (version.c). */
const char *voxlab_version(void);

#include "cli.h"
/* Each command's --help: synopsis, summary, options with defaults (in its cmd_*.c). */
extern const cli_command cmd_truth_help, cmd_compare_help, cmd_bake_help, cmd_render_help, cmd_models_help;

#endif
