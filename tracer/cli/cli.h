/* Shared command-line helpers for the voxlab subcommands. */
#ifndef VX_CLI_H
#define VX_CLI_H

#include <stdint.h>

/* Parses a whole decimal integer in [lo, hi] given to `option`; prints an error and returns -1. */
int cli_int(const char *cmd, const char *option, const char *text, long long lo, long long hi, long long *out);
/* The argument after argv[*i] (advancing *i); prints an error naming the option when missing. */
const char *cli_value(const char *cmd, int argc, char **argv, int *i);

#endif
