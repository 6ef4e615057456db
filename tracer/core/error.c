#include "error.h"

#include <stdarg.h>
#include <stdio.h>

int vx_fail(vx_err *e, const char *fmt, ...)
{
    if (e) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(e->msg, sizeof e->msg, fmt, ap);
        va_end(ap);
    }
    return -1;
}

int vx_wrap(vx_err *e, const char *fmt, ...)
{
    if (!e)
        return -1;
    char prefix[512], inner[sizeof e->msg];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap);
    va_end(ap);
    snprintf(inner, sizeof inner, "%s", e->msg);
    snprintf(e->msg, sizeof e->msg, "%s: %s", prefix, inner);
    return -1;
}
