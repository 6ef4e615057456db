/* Shared command-line helpers for the voxlab subcommands. */
#ifndef VX_CLI_H
#define VX_CLI_H

#include <stdint.h>

#include <stdio.h>

/* --threads' upper bound, one for every command (truth once took up to 2^20, render and bake 1024). */
#define CLI_MAX_THREADS 1024

/* One option of a subcommand, for its --help (and the test that each listed option is accepted). */
typedef struct {
    const char *flag;     /* "--spp" */
    const char *value;    /* "N", or NULL for a switch */
    const char *fallback; /* the default, as text ("1024", "the scene's", "every core"), or NULL: none */
    const char *help;     /* one line */
} cli_option;

typedef struct {
    const char *name;     /* "truth" */
    const char *synopsis; /* the usage line(s), without "usage: " */
    const char *summary;  /* one line: what the command does */
    const cli_option *options; /* terminated by {0} */
} cli_command;

/* 1 when argv (after the subcommand) asks for help: -h or --help anywhere. */
int cli_wants_help(int argc, char **argv);
/* The command's synopsis, summary and options with their defaults. */
void cli_print_help(const cli_command *c, FILE *f);

/* Parses a whole decimal integer in [lo, hi] given to `option`; prints an error and returns -1. */
int cli_int(const char *cmd, const char *option, const char *text, long long lo, long long hi, long long *out);
/* The argument after argv[*i] (advancing *i); prints an error naming the option when missing. */
const char *cli_value(const char *cmd, int argc, char **argv, int *i);

#endif
