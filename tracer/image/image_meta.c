#include "image_meta.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

void image_meta_add(image_meta *m, const char *name, const char *fmt, ...)
{
    if (m->count >= IMAGE_META_MAX)
        return;
    image_meta_entry *x = &m->entry[m->count++];
    snprintf(x->key, sizeof x->key, IMAGE_META_PREFIX "%s", name);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(x->value, sizeof x->value, fmt, ap);
    va_end(ap);
}

void image_meta_add_command(image_meta *m, int argc, char **argv)
{
    char text[1024] = "voxlab";
    size_t len = strlen(text);
    for (int i = 0; i < argc && len + 4 < sizeof text; i++) {
        const char *a = argv[i];
        int plain = *a != 0;
        for (const char *c = a; *c; c++)
            plain &= !strchr(" \t\n'\"\\$`*?[]{}()<>|&;#~", *c);
        int n = plain ? snprintf(text + len, sizeof text - len, " %s", a) : snprintf(text + len, sizeof text - len, " '");
        len += n > 0 ? (size_t)n : 0;
        if (!plain) {
            for (const char *c = a; *c && len + 6 < sizeof text; c++)
                len += (size_t)snprintf(text + len, sizeof text - len, *c == '\'' ? "'\\''" : "%c", *c);
            if (len + 2 < sizeof text)
                text[len++] = '\'', text[len] = 0;
        }
        if (len >= sizeof text)
            len = sizeof text - 1;
    }
    image_meta_add(m, "command", "%s", text);
}
