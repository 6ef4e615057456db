/* Opens the OpenImageIO plugin (build/libvoxlab_oiio.so, see image_oiio.cpp) on first use and
 * forwards image_read and image_write_png8_oiio to it. Looked for at $VOXLAB_OIIO_PLUGIN, else beside
 * build/libvoxlab.so when this code runs from that library, else beside the executable, then one
 * directory up (the test programs live in build/tests/). */
#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "image.h"

typedef int (*read_fn)(const char *, image *, vx_err *);
typedef int (*png_fn)(const unsigned char *, int, int, int, const char *, const char *, vx_err *);

static pthread_once_t plugin_once = PTHREAD_ONCE_INIT;
static read_fn plugin_read;
static png_fn plugin_png;
static char plugin_error[1024] = "not loaded";

static int try_open(const char *path)
{
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        const char *why = dlerror();
        snprintf(plugin_error, sizeof plugin_error, "cannot load %s: %s", path, why ? why : "?");
        return 0;
    }
    plugin_read = (read_fn)dlsym(h, "vx_oiio_read");
    plugin_png = (png_fn)dlsym(h, "vx_oiio_write_png8");
    if (!plugin_read || !plugin_png) {
        snprintf(plugin_error, sizeof plugin_error, "%s lacks the voxlab entry points", path);
        plugin_read = NULL;
        plugin_png = NULL;
        return 0;
    }
    return 1;
}

/* The directory of the file that holds this code: build/libvoxlab.so when the library is loaded
 * into another program (Python through tracer/api/), where /proc/self/exe names the interpreter.
 * Empty when this code is in the executable itself. That library is also made global, since the
 * plugin calls back into it (vx_fail, image_alloc, image_free) and a library opened with
 * RTLD_LOCAL (ctypes' default) would not supply those symbols. */
static void library_dir(char *out, size_t size, const char *exe_path)
{
    Dl_info info;
    char lib[PATH_MAX];
    out[0] = 0;
    if (!dladdr((void *)library_dir, &info) || !info.dli_fname || !strchr(info.dli_fname, '/') ||
        !realpath(info.dli_fname, lib) || strcmp(lib, exe_path) == 0)
        return;
    dlopen(lib, RTLD_NOW | RTLD_NOLOAD | RTLD_GLOBAL);
    char *slash = strrchr(lib, '/');
    *slash = 0;
    snprintf(out, size, "%s", lib);
}

static void load_plugin(void)
{
    const char *env = getenv("VOXLAB_OIIO_PLUGIN");
    if (env && *env) {
        try_open(env);
        return;
    }
    char exe[PATH_MAX], dir[PATH_MAX], path[PATH_MAX + 64];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0) {
        snprintf(plugin_error, sizeof plugin_error, "cannot locate the executable to find libvoxlab_oiio.so");
        return;
    }
    exe[n] = 0;
    library_dir(dir, sizeof dir, exe);
    if (dir[0]) {
        snprintf(path, sizeof path, "%s/libvoxlab_oiio.so", dir);
        try_open(path);
        return;
    }
    char *slash = strrchr(exe, '/');
    if (slash)
        *slash = 0;
    snprintf(path, sizeof path, "%s/libvoxlab_oiio.so", exe);
    if (try_open(path))
        return;
    snprintf(path, sizeof path, "%s/../libvoxlab_oiio.so", exe);
    try_open(path);
}

int image_read(const char *path, image *out, vx_err *e)
{
    pthread_once(&plugin_once, load_plugin);
    if (!plugin_read) {
        memset(out, 0, sizeof *out);
        return vx_fail(e, "cannot read %s: the OpenImageIO plugin is unavailable: %s", path, plugin_error);
    }
    return plugin_read(path, out, e);
}

int image_write_png8_oiio(const unsigned char *px, int width, int height, int channels, const char *path,
                          const char *what, vx_err *e)
{
    pthread_once(&plugin_once, load_plugin);
    if (!plugin_png)
        return vx_fail(e, "cannot write %s: the OpenImageIO plugin is unavailable: %s", what, plugin_error);
    return plugin_png(px, width, height, channels, path, what, e);
}
