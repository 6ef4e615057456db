#include "json_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *json_sep(const char *where)
{
    size_t n = strlen(where);
    return n && where[n - 1] == ':' ? " " : ".";
}

int json_number(const cJSON *obj, const char *field, const char *where, double *out, vx_err *e)
{
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(obj, field);
    if (!f)
        return 0;
    if (!cJSON_IsNumber(f) || !isfinite(f->valuedouble))
        return vx_fail(e, "%s%s%s: expected a finite number", where, json_sep(where), field);
    *out = f->valuedouble;
    return 0;
}

int json_float(const cJSON *obj, const char *field, const char *where, float *out, vx_err *e)
{
    double d = *out;
    if (json_number(obj, field, where, &d, e))
        return -1;
    if (fabs(d) > 3.0e38)
        return vx_fail(e, "%s%s%s: %g does not fit a float", where, json_sep(where), field, d);
    *out = (float)d;
    return 0;
}

int json_number_in(const cJSON *obj, const char *field, const char *where, double lo, double hi, double *out,
                   vx_err *e)
{
    if (!cJSON_GetObjectItemCaseSensitive(obj, field))
        return 0; /* absent: the caller's default stands, whatever it is */
    if (json_number(obj, field, where, out, e))
        return -1;
    if (*out < lo || *out > hi)
        return vx_fail(e, "%s%s%s: %g is out of range (expected %g to %g)", where, json_sep(where), field, *out, lo, hi);
    return 0;
}

int json_int(const cJSON *obj, const char *field, const char *where, int *out, vx_err *e)
{
    return json_int_in(obj, field, where, -2147483647, 2147483647, out, e);
}

int json_int_in(const cJSON *obj, const char *field, const char *where, int lo, int hi, int *out, vx_err *e)
{
    double d = *out;
    if (!cJSON_GetObjectItemCaseSensitive(obj, field))
        return 0;
    if (json_number(obj, field, where, &d, e))
        return -1;
    if (d != floor(d))
        return vx_fail(e, "%s%s%s: expected an integer, got %g", where, json_sep(where), field, d);
    if (d < lo || d > hi)
        return vx_fail(e, "%s%s%s: %g is out of range (expected %d to %d)", where, json_sep(where), field, d, lo, hi);
    *out = (int)d;
    return 0;
}

int json_u64(const cJSON *obj, const char *field, const char *where, uint64_t *out, vx_err *e)
{
    double d = (double)*out;
    if (json_number(obj, field, where, &d, e))
        return -1;
    if (d != floor(d) || d < 0 || d > 9007199254740992.0)
        return vx_fail(e, "%s%s%s: expected a non-negative integer, got %g", where, json_sep(where), field, d);
    *out = (uint64_t)d;
    return 0;
}

int json_bool(const cJSON *obj, const char *field, const char *where, int *out, vx_err *e)
{
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(obj, field);
    if (!f)
        return 0;
    if (!cJSON_IsBool(f))
        return vx_fail(e, "%s%s%s: expected true or false", where, json_sep(where), field);
    *out = cJSON_IsTrue(f);
    return 0;
}

int json_vec3(const cJSON *obj, const char *field, const char *where, vec3 *out, vx_err *e)
{
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(obj, field);
    if (!f)
        return 0;
    if (!cJSON_IsArray(f) || cJSON_GetArraySize(f) != 3)
        return vx_fail(e, "%s%s%s: expected an array of 3 numbers", where, json_sep(where), field);
    float c[3];
    for (int i = 0; i < 3; i++) {
        const cJSON *x = cJSON_GetArrayItem(f, i);
        if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble) || fabs(x->valuedouble) > 3.0e38)
            return vx_fail(e, "%s%s%s[%d]: expected a finite number", where, json_sep(where), field, i);
        c[i] = (float)x->valuedouble;
    }
    *out = v3(c[0], c[1], c[2]);
    return 0;
}

int json_string(const cJSON *obj, const char *field, const char *where, const char **out, vx_err *e)
{
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(obj, field);
    if (!f)
        return 0;
    if (!cJSON_IsString(f))
        return vx_fail(e, "%s%s%s: expected a string", where, json_sep(where), field);
    *out = f->valuestring;
    return 0;
}

int json_only_fields(const cJSON *obj, const char *where, const char *const *known, vx_err *e)
{
    const cJSON *f;
    cJSON_ArrayForEach(f, obj)
    {
        int ok = 0;
        for (const char *const *k = known; *k; k++)
            if (f->string && strcmp(f->string, *k) == 0)
                ok = 1;
        if (!ok)
            return vx_fail(e, "%s: unknown field \"%s\"", where, f->string ? f->string : "?");
    }
    return 0;
}

/* The 1-based line of `at` in `text`. */
static int line_of(const char *text, const char *at)
{
    int line = 1;
    for (const char *c = text; at && *c && c < at; c++)
        line += *c == '\n';
    return line;
}

int json_nothing_after(const char *text, const char *end, const char *where, vx_err *e)
{
    const char *c = end;
    while (*c == ' ' || *c == '\t' || *c == '\n' || *c == '\r') /* JSON's whitespace (RFC 8259) */
        c++;
    if (!*c)
        return 0;
    int shown = 0; /* quote at most 20 characters of it, and of its first line only */
    while (shown < 20 && c[shown] && c[shown] != '\n' && c[shown] != '\r')
        shown++;
    return vx_fail(e, "%s: line %d: text after the JSON document (\"%.*s\"): expected the end of the file", where,
                   line_of(text, c), shown, c);
}

static int by_key(const void *a, const void *b)
{
    return strcmp((*(const cJSON *const *)a)->string, (*(const cJSON *const *)b)->string);
}

/* The members of one object, sorted by key, so that a repeated key is a neighbour: n log n, not n^2
 * (a generated scene may hold an object of many thousands of materials). Returns 0, or -1 with e
 * naming the first repeated key under `path`. */
static int object_keys_unique(const cJSON *obj, const char *where, const char *path, vx_err *e)
{
    int n = cJSON_GetArraySize(obj);
    if (n < 2)
        return 0;
    const cJSON **keys = malloc(sizeof *keys * (size_t)n);
    if (!keys)
        return vx_fail(e, "%s: out of memory checking %s's keys", where, *path ? path : "the top level");
    int k = 0;
    for (const cJSON *c = obj->child; c && k < n; c = c->next)
        keys[k++] = c;
    qsort(keys, (size_t)k, sizeof *keys, by_key);
    int rc = 0;
    for (int i = 1; i < k && !rc; i++)
        if (strcmp(keys[i - 1]->string, keys[i]->string) == 0)
            rc = vx_fail(e, "%s: %s%s%s appears twice: expected each key once (which value counts would be a guess)",
                         where, path, *path ? "." : "", keys[i]->string);
    free(keys);
    return rc;
}

/* Depth first, with path[0..len) the node's own path ("camera", "objects[2].transform"; "" at the
 * top), one buffer for the whole walk (its depth is bounded by cJSON's nesting limit, 1000); a
 * path longer than the buffer is cut short in the message, never overflows. */
static int unique_keys_under(const cJSON *node, const char *where, char *path, size_t len, size_t cap, vx_err *e)
{
    if (cJSON_IsObject(node) && object_keys_unique(node, where, path, e))
        return -1;
    int i = 0;
    for (const cJSON *c = node->child; c; c = c->next, i++) {
        if (!cJSON_IsObject(c) && !cJSON_IsArray(c))
            continue;
        int n = cJSON_IsObject(node) ? snprintf(path + len, cap - len, "%s%s", len ? "." : "", c->string)
                                     : snprintf(path + len, cap - len, "[%d]", i);
        size_t sub = n < 0 ? len : len + (size_t)n < cap ? len + (size_t)n : cap - 1;
        int rc = unique_keys_under(c, where, path, sub, cap, e);
        path[len] = 0;
        if (rc)
            return -1;
    }
    return 0;
}

int json_unique_keys(const cJSON *root, const char *where, vx_err *e)
{
    char path[512] = "";
    return unique_keys_under(root, where, path, 0, sizeof path, e);
}

cJSON *json_parse_strict(const char *text, const char *where, vx_err *e)
{
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithOpts(text, &end, 0); /* on failure, end is where it failed */
    if (!root) {
        vx_fail(e, "%s: malformed JSON near line %d", where, line_of(text, end));
        return NULL;
    }
    if (json_nothing_after(text, end, where, e) || json_unique_keys(root, where, e)) {
        cJSON_Delete(root);
        return NULL;
    }
    return root;
}
