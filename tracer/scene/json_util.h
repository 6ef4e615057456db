/* Typed reads of cJSON fields with errors that name the file, the field and what was expected.
 * `where` is the field's parent path for messages, e.g. "scenes/trees.json: objects[1].params"
 * (then "...params.size: ..."); for a field at a file's top level it is the file name and a colon,
 * "scenes/trees.json:" (then "scenes/trees.json: size: ...", not "scenes/trees.json.size"). */
#ifndef VX_JSON_UTIL_H
#define VX_JSON_UTIL_H

#include <cjson/cJSON.h>
#include <stdint.h>

#include "error.h"
#include "vec.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What joins `where` and a field in a message: "." below an object, " " after "file:". */
const char *json_sep(const char *where);

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

/* Parsing a whole file as one JSON document, strictly: cJSON alone accepts text after the document
 * (cJSON_Parse stops at its end) and keeps every value of a repeated key (lookups find the first),
 * so a file that another JSON reader takes differently (most keep the last value) would load
 * without a word. `where` names the document in messages ("scenes/trees.json").
 *
 * The tree of `text` (NUL-terminated), or NULL with "WHERE: malformed JSON near line N", "WHERE:
 * line N: text after the JSON document ..." or "WHERE: KEY.PATH appears twice ...". */
cJSON *json_parse_strict(const char *text, const char *where, vx_err *e);
/* Its two checks, for a caller that parses itself: only whitespace from `end` (where the document
 * ended in `text`) on, and no object anywhere under `root` with a key twice. */
int json_nothing_after(const char *text, const char *end, const char *where, vx_err *e);
int json_unique_keys(const cJSON *root, const char *where, vx_err *e);

#ifdef __cplusplus
}
#endif

#endif
