/* Whole-file output that never leaves a partial file: write to a temporary name beside the target,
 * then rename. Every temporary file is removed on failure, and on the signals that end a run. */
#ifndef VX_FILEIO_H
#define VX_FILEIO_H

#include <stddef.h>
#include <stdio.h>

#include "error.h"

/* Creates an empty, uniquely named file "<path>.tmp.<pid>.<n>" beside path (so the final rename
 * stays within one file system) and puts its name in tmp. Fails with a message naming path and the
 * reason (e.g. the directory is missing or not writable). For writers that open the file by name
 * (the OpenEXR and OpenImageIO writers). */
int fileio_temp_create(const char *path, char *tmp, size_t tmp_size, vx_err *e);
/* Removes a temporary file after a failure (and forgets it: see fileio_install_signal_cleanup). */
void fileio_temp_discard(const char *tmp);
/* Renames a finished temporary file to path; removes it when that fails. */
int fileio_temp_commit(const char *tmp, const char *path, vx_err *e);

/* fileio_temp_create, then opened for writing as a stdio stream. */
FILE *fileio_open_temp(const char *path, char *tmp_path, size_t tmp_size, vx_err *e);
/* Closes f and renames tmp_path to path; on any error removes tmp_path. */
int fileio_commit(FILE *f, const char *tmp_path, const char *path, vx_err *e);
/* Closes f and removes tmp_path (after a failure). */
void fileio_abort(FILE *f, const char *tmp_path);
int fileio_write_text(const char *path, const char *text, vx_err *e);
/* Fails early, before long work, when `path` cannot be created (creates and removes a temp file)
 * or is a directory. */
int fileio_check_writable(const char *path, vx_err *e);
/* path's extension: from the last '.' of its last component ("" when it has none; a leading '.',
 * as in ".exr", starts a hidden file's name, not an extension). */
const char *fileio_extension(const char *path);
/* fileio_check_writable, then the extension: ext, in any case (as images take .EXR), so that a
 * file that a later run or a script would read as the wrong kind is not written under that name.
 * The message names the option: "--stats s.exr: unsupported extension '.exr' (expected .json)". */
int fileio_check_output(const char *option, const char *path, const char *ext, vx_err *e);

/* Installs handlers for SIGINT, SIGTERM, SIGHUP and SIGXFSZ (those not ignored) that remove every
 * temporary file being written and then end the process by the same signal. Called once by main. */
void fileio_install_signal_cleanup(void);

#endif
