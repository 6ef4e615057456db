/* The voxlab subcommands (argv[0] is the subcommand's name; each returns the exit status). */
#ifndef VX_COMMANDS_H
#define VX_COMMANDS_H

#include <cjson/cJSON.h>

#include "scene.h"

int cmd_truth(int argc, char **argv);
int cmd_compare(int argc, char **argv);

/* --stats JSON helpers: the scene's fields, and writing the object atomically to path. */
cJSON *stats_scene_fields(const scene *s);
int stats_write(cJSON *j, const char *path, const char *cmd);

#endif
