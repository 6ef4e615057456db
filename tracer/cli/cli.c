#include "cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int cli_wants_help(int argc, char **argv)
{
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0)
            return 1;
    return 0;
}

void cli_print_help(const cli_command *c, FILE *f)
{
    fprintf(f, "usage: %s\n\n%s\n\noptions:\n", c->synopsis, c->summary);
    for (const cli_option *o = c->options; o->flag; o++) {
        char head[64];
        snprintf(head, sizeof head, "%s%s%s", o->flag, o->value ? " " : "", o->value ? o->value : "");
        fprintf(f, "  %-20s %s", head, o->help);
        if (o->fallback)
            fprintf(f, " (default: %s)", o->fallback);
        fputc('\n', f);
    }
}

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
