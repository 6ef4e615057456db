/* voxlab: the command-line entry point. Each subcommand lives in its own cmd_*.c. */
#include <stdio.h>
#include <string.h>

#include "commands.h"
#include "fileio.h"

static const char usage[] =
    "voxlab — voxel appearance models against an Embree ground truth\n"
    "\n"
    "usage:\n"
    "  voxlab truth   SCENE [--spp N] [--size WxH] [--seed S] [--threads T] -o OUT.exr|png [--stats S.json]\n"
    "  voxlab bake    SCENE --model M --res N [--rays K] [--seed S] [--threads T] -o OUT.vox [--stats S.json]\n"
    "  voxlab render  SCENE --model M (--res N [--rays K] | --vox FILE) [--spp N] [--size WxH] [--seed S]\n"
    "                 [--threads T] [--no-cache] [--no-shadow-skip] -o OUT.exr|png [--stats S.json]\n"
    "  voxlab compare A B [--json] [--heatmap OUT.png]\n"
    "  voxlab models  (lists the appearance models)\n"
    "\n"
    "See README.md for the scene format and what each command writes.\n";

int main(int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "help") == 0) {
        fputs(usage, argc < 2 ? stderr : stdout);
        return argc < 2 ? 1 : 0;
    }
    fileio_install_signal_cleanup(); /* no temporary file outlives Ctrl-C, SIGTERM or the file-size limit */
    static const struct {
        const char *name;
        int (*run)(int, char **);
    } commands[] = {
        {"truth", cmd_truth},
        {"compare", cmd_compare},
        {"bake", cmd_bake},
        {"render", cmd_render},
        {"models", cmd_models},
    };
    for (size_t i = 0; i < sizeof commands / sizeof *commands; i++)
        if (strcmp(argv[1], commands[i].name) == 0)
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "voxlab: unknown command \"%s\"\n\n%s", argv[1], usage);
    return 1;
}
