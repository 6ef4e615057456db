#include "opencl_pick.h"

#include <ctype.h>
#include <stddef.h>
#include <strings.h>

static int contains_ignoring_case(const char *hay, const char *needle)
{
    for (; *hay; hay++) {
        size_t i = 0;
        while (needle[i] && hay[i] && tolower((unsigned char)hay[i]) == tolower((unsigned char)needle[i]))
            i++;
        if (!needle[i])
            return 1;
    }
    return !*needle;
}

int opencl_pick_device(const opencl_device_desc *d, int n, const char *want)
{
    int by_kind = !want || !*want || !strcasecmp(want, "gpu") || !strcasecmp(want, "cpu");
    if (!by_kind) {
        for (int i = 0; i < n; i++)
            if (d[i].fp64 && contains_ignoring_case(d[i].name, want))
                return i;
        return -1;
    }
    int first_cpu = -1;
    for (int i = 0; i < n; i++) {
        if (!d[i].fp64)
            continue;
        if (!d[i].cpu && !(want && !strcasecmp(want, "cpu")))
            return i;
        if (d[i].cpu && first_cpu < 0)
            first_cpu = i;
    }
    return want && !strcasecmp(want, "gpu") ? -1 : first_cpu;
}
