/* Shared by the libFuzzer harnesses (tests/fuzz/fuzz_*.c): the loaders under test read files by
 * path, as voxlab does, so each input is written to a file in a private folder first. The folder
 * also holds copies of the test fixtures, so that mutated scenes can still name a loadable mesh. */
#ifndef VX_FUZZ_COMMON_H
#define VX_FUZZ_COMMON_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char fuzz_dir[64];

/* The private folder (created once), with tests/data's fixtures copied in. */
static const char *fuzz_folder(void)
{
    if (fuzz_dir[0])
        return fuzz_dir;
    snprintf(fuzz_dir, sizeof fuzz_dir, "/tmp/voxlab_fuzz.XXXXXX");
    if (!mkdtemp(fuzz_dir)) {
        perror("mkdtemp");
        abort();
    }
    const char *src = getenv("VOXLAB_FUZZ_FIXTURES"); /* set by tests/fuzz/run.sh */
    if (src) {
        char cmd[1024];
        snprintf(cmd, sizeof cmd, "cp -r '%s'/. '%s'/ 2>/dev/null", src, fuzz_dir);
        if (system(cmd) != 0)
            fprintf(stderr, "fuzz: could not copy the fixtures from %s\n", src);
    }
    return fuzz_dir;
}

/* Writes data to <folder>/<name>; returns the path (static storage). */
static const char *fuzz_write(const char *name, const uint8_t *data, size_t size)
{
    static char path[256];
    snprintf(path, sizeof path, "%s/%s", fuzz_folder(), name);
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror(path);
        abort();
    }
    return path;
}

#endif
