/* voxlab: the command-line entry point. Each subcommand lives in its own cmd_*.c and describes its
 * options (cli_command) for --help. */
#include <stdio.h>
#include <string.h>

#include "commands.h"
#include "fileio.h"

static const struct {
    int (*run)(int, char **);
    const cli_command *help;
} commands[] = {
    {cmd_truth, &cmd_truth_help},   {cmd_bake, &cmd_bake_help},     {cmd_render, &cmd_render_help},
    {cmd_compare, &cmd_compare_help}, {cmd_models, &cmd_models_help},
};
#define COMMANDS (sizeof commands / sizeof *commands)

static void usage(FILE *f)
{
    fprintf(f, "voxlab %s — voxel appearance models against an Embree ground truth\n\nusage:\n", voxlab_version());
    for (size_t i = 0; i < COMMANDS; i++)
        fprintf(f, "  %s\n", commands[i].help->synopsis);
    fprintf(f, "\ncommands:\n");
    for (size_t i = 0; i < COMMANDS; i++)
        fprintf(f, "  %-8s %s\n", commands[i].help->name, commands[i].help->summary);
    fprintf(f, "\n`voxlab COMMAND --help` lists a command's options and their defaults; `voxlab --version`.\n"
               "See README.md for the scene format and what each command writes.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "help") == 0) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? 1 : 0;
    }
    if (strcmp(argv[1], "--version") == 0 || strcmp(argv[1], "version") == 0) {
        printf("voxlab %s\nbuild: %s\n", voxlab_version(), voxlab_build());
        return 0;
    }
    fileio_install_signal_cleanup(); /* no temporary file outlives Ctrl-C, SIGTERM or the file-size limit */
    for (size_t i = 0; i < COMMANDS; i++)
        if (strcmp(argv[1], commands[i].help->name) == 0)
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "voxlab: unknown command \"%s\"\n\n", argv[1]);
    usage(stderr);
    return 1;
}
