#include "json_util.h"

#include <math.h>
#include <string.h>

int json_number(const cJSON *obj, const char *field, const char *where, double *out, vx_err *e)
{
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(obj, field);
    if (!f)
        return 0;
    if (!cJSON_IsNumber(f) || !isfinite(f->valuedouble))
        return vx_fail(e, "%s.%s: expected a finite number", where, field);
    *out = f->valuedouble;
    return 0;
}

int json_float(const cJSON *obj, const char *field, const char *where, float *out, vx_err *e)
{
    double d = *out;
    if (json_number(obj, field, where, &d, e))
        return -1;
    if (fabs(d) > 3.0e38)
        return vx_fail(e, "%s.%s: %g does not fit a float", where, field, d);
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
        return vx_fail(e, "%s.%s: %g is out of range (expected %g to %g)", where, field, *out, lo, hi);
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
        return vx_fail(e, "%s.%s: expected an integer, got %g", where, field, d);
    if (d < lo || d > hi)
        return vx_fail(e, "%s.%s: %g is out of range (expected %d to %d)", where, field, d, lo, hi);
    *out = (int)d;
    return 0;
}

int json_u64(const cJSON *obj, const char *field, const char *where, uint64_t *out, vx_err *e)
{
    double d = (double)*out;
    if (json_number(obj, field, where, &d, e))
        return -1;
    if (d != floor(d) || d < 0 || d > 9007199254740992.0)
        return vx_fail(e, "%s.%s: expected a non-negative integer, got %g", where, field, d);
    *out = (uint64_t)d;
    return 0;
}

int json_bool(const cJSON *obj, const char *field, const char *where, int *out, vx_err *e)
{
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(obj, field);
    if (!f)
        return 0;
    if (!cJSON_IsBool(f))
        return vx_fail(e, "%s.%s: expected true or false", where, field);
    *out = cJSON_IsTrue(f);
    return 0;
}

int json_vec3(const cJSON *obj, const char *field, const char *where, vec3 *out, vx_err *e)
{
    const cJSON *f = cJSON_GetObjectItemCaseSensitive(obj, field);
    if (!f)
        return 0;
    if (!cJSON_IsArray(f) || cJSON_GetArraySize(f) != 3)
        return vx_fail(e, "%s.%s: expected an array of 3 numbers", where, field);
    float c[3];
    for (int i = 0; i < 3; i++) {
        const cJSON *x = cJSON_GetArrayItem(f, i);
        if (!cJSON_IsNumber(x) || !isfinite(x->valuedouble) || fabs(x->valuedouble) > 3.0e38)
            return vx_fail(e, "%s.%s[%d]: expected a finite number", where, field, i);
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
        return vx_fail(e, "%s.%s: expected a string", where, field);
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
