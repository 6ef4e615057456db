/* Error reporting: every failing call fills a vx_err with a message that names the file and the
 * field (or the operation) and what was expected, and returns -1. Callers print it and exit
 * non-zero; nothing here exits, so library code stays usable from tests. */
#ifndef VX_ERROR_H
#define VX_ERROR_H

#include <stddef.h>

typedef struct {
    char msg[1024];
} vx_err;

#ifdef __cplusplus
extern "C" {
#endif

/* Formats the message into e (when e is not NULL) and returns -1, so `return vx_fail(...)` reads well. */
int vx_fail(vx_err *e, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Prefixes the message already in e with a formatted context ("scene.json: objects[2]") and
 * returns -1, for errors passed up through a layer that knows more about where they came from. */
int vx_wrap(vx_err *e, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#ifdef __cplusplus
}
#endif

#endif
