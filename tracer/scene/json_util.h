/* Typed reads of cJSON fields with errors that name the file, the field and what was expected.
 * `where` is the field's parent path for messages, e.g. "scenes/trees.json: objects[1].params". */
#ifndef VX_JSON_UTIL_H
#define VX_JSON_UTIL_H

#include <cjson/cJSON.h>
#include <stdint.h>

#include "error.h"
#include "vec.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Each returns 0 when the field is absent (leaving *out at the default already in it), 0 when it is
 * present and valid, and -1 (with e filled) when it is present but of the wrong type or not finite. */
int json_number(const cJSON *obj, const char *field, const char *where, double *out, vx_err *e);
int json_float(const cJSON *obj, const char *field, const char *where, float *out, vx_err *e);
int json_int(const cJSON *obj, const char *field, const char *where, int *out, vx_err *e);
int json_u64(const cJSON *obj, const char *field, const char *where, uint64_t *out, vx_err *e);
int json_bool(const cJSON *obj, const char *field, const char *where, int *out, vx_err *e);
int json_vec3(const cJSON *obj, const char *field, const char *where, vec3 *out, vx_err *e);
/* *out points into the cJSON tree (valid while it lives). */
int json_string(const cJSON *obj, const char *field, const char *where, const char **out, vx_err *e);
/* Checks a number lies in [lo, hi]. */
int json_number_in(const cJSON *obj, const char *field, const char *where, double lo, double hi, double *out,
                   vx_err *e);
int json_int_in(const cJSON *obj, const char *field, const char *where, int lo, int hi, int *out, vx_err *e);

/* Rejects fields not in the NULL-terminated list `known` (catches typos such as "efects"). */
int json_only_fields(const cJSON *obj, const char *where, const char *const *known, vx_err *e);

#ifdef __cplusplus
}
#endif

#endif
