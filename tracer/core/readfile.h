/* Reading input files safely: only regular files (a directory, a FIFO or /dev/zero is refused up
 * front instead of being read as a file of absurd size, blocking, or never ending), with a size cap
 * so that a huge file is a clear error rather than an allocation the machine cannot make. */
#ifndef VX_READFILE_H
#define VX_READFILE_H

#include <stddef.h>
#include <sys/types.h>

#include "error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Largest input file read whole (scene JSON, PLY, glTF, .vox): 8 GiB. */
#define READFILE_MAX_BYTES (8ULL << 30)

/* Opens path read-only after checking that it is a regular file of at most max_bytes; returns the
 * descriptor (its size in *size) or -1 with "PATH: cannot open WHAT: why" / "PATH: WHAT is a
 * directory, not a file" / ... Never blocks on a FIFO. */
int readfile_open(const char *path, const char *what, unsigned long long max_bytes, off_t *size, vx_err *e);

/* The whole regular file, malloc'ed and NUL-terminated (*size excludes the NUL); NULL on failure
 * with a message naming path and what. */
char *readfile_all(const char *path, const char *what, unsigned long long max_bytes, size_t *size, vx_err *e);

/* Only the checks of readfile_open (regular file, size cap), for readers that open the file
 * themselves (OpenImageIO). */
int readfile_check(const char *path, const char *what, unsigned long long max_bytes, vx_err *e);

#ifdef __cplusplus
}
#endif

#endif
