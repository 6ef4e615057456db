#include "cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>

int cli_int(const char *cmd, const char *option, const char *text, long long lo, long long hi, long long *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(text, &end, 10);
    if (errno || end == text || *end || v < lo || v > hi) {
        fprintf(stderr, "voxlab %s: %s %s: expected an integer from %lld to %lld\n", cmd, option, text, lo, hi);
        return -1;
    }
    *out = v;
    return 0;
}

const char *cli_value(const char *cmd, int argc, char **argv, int *i)
{
    if (*i + 1 >= argc) {
        fprintf(stderr, "voxlab %s: %s needs a value\n", cmd, argv[*i]);
        return NULL;
    }
    return argv[++*i];
}
