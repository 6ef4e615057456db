#include "opencl_program.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "embedded_sources.h"

#define MAX_INCLUDE_DEPTH 32

typedef struct {
    char *s;
    size_t len, cap;
    int failed; /* out of memory */
} text;

static void put(text *t, const char *s, size_t n)
{
    if (t->failed)
        return;
    if (t->len + n + 1 > t->cap) {
        size_t cap = t->cap ? t->cap : 1 << 16;
        while (t->len + n + 1 > cap)
            cap *= 2;
        char *p = realloc(t->s, cap);
        if (!p) {
            t->failed = 1;
            return;
        }
        t->s = p;
        t->cap = cap;
    }
    memcpy(t->s + t->len, s, n);
    t->len += n;
    t->s[t->len] = 0;
}

static void puts_(text *t, const char *s) { put(t, s, strlen(s)); }

/* A #line marker: what follows is line `line` of `file` (for the compiler's messages). */
static void put_line_marker(text *t, long line, const char *file)
{
    char marker[PATH_MAX + 64];
    snprintf(marker, sizeof marker, "#line %ld \"%s\"\n", line, file);
    puts_(t, marker);
}

/* The embedded source at `rel` (a path from the repository root), or NULL. */
static const vx_embedded_source *embedded(const char *rel)
{
    for (const vx_embedded_source *f = vx_embedded_sources; f->path; f++)
        if (strcmp(f->path, rel) == 0)
            return f;
    return NULL;
}

int opencl_build_dir(char *build_dir, size_t build_size, vx_err *e)
{
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0)
        return vx_fail(e, "cannot locate the executable (/proc/self/exe), where the OpenCL kernel cache goes");
    exe[n] = 0;
    char *slash = strrchr(exe, '/');
    if (slash)
        *slash = 0;
    snprintf(build_dir, build_size, "%s", exe);
    return 0;
}

/* The quoted name of an `#include "name"` line, or 0. */
static int include_name(const char *line, size_t len, char *name, size_t name_size)
{
    size_t i = 0;
    while (i < len && (line[i] == ' ' || line[i] == '\t'))
        i++;
    if (i >= len || line[i] != '#')
        return 0;
    i++;
    while (i < len && (line[i] == ' ' || line[i] == '\t'))
        i++;
    if (len - i < 7 || strncmp(line + i, "include", 7) != 0)
        return 0;
    i += 7;
    while (i < len && (line[i] == ' ' || line[i] == '\t'))
        i++;
    if (i >= len || line[i] != '"')
        return 0;
    size_t start = ++i;
    while (i < len && line[i] != '"')
        i++;
    if (i >= len || i - start + 1 > name_size)
        return 0;
    memcpy(name, line + start, i - start);
    name[i - start] = 0;
    return 1;
}

typedef struct {
    const char *stack[MAX_INCLUDE_DEPTH]; /* files being expanded (relative to src) */
    int depth;
    vx_err *e;
} expander;

/* Finds `name` beside the including file (rel_dir, relative to the tree), then in the folders of
 * the C build's -I path (vx_source_dirs), among the embedded sources; fills rel. */
static int resolve(const char *rel_dir, const char *name, char *rel, size_t rel_size)
{
    if (*rel_dir) {
        snprintf(rel, rel_size, "%s/%s", rel_dir, name);
        if (embedded(rel))
            return 1;
    }
    for (const char *const *dir = vx_source_dirs; *dir; dir++) {
        snprintf(rel, rel_size, "%s/%s", *dir, name);
        if (embedded(rel))
            return 1;
    }
    return 0;
}

static int expand_text(expander *x, text *out, const char *body, const char *rel);

/* Appends embedded file `rel` with its includes expanded. */
static int expand_file(expander *x, text *out, const char *rel)
{
    const vx_embedded_source *f = embedded(rel);
    if (!f)
        return vx_fail(x->e, "OpenCL sources: %s is not among the sources embedded at build time", rel);
    return expand_text(x, out, f->text, rel);
}

static int expand_text(expander *x, text *out, const char *body, const char *rel)
{
    if (x->depth >= MAX_INCLUDE_DEPTH)
        return vx_fail(x->e, "OpenCL sources: #include nested deeper than %d at %s", MAX_INCLUDE_DEPTH, rel);
    x->stack[x->depth++] = rel;
    char rel_dir[PATH_MAX];
    snprintf(rel_dir, sizeof rel_dir, "%s", rel);
    char *slash = strrchr(rel_dir, '/');
    if (slash)
        *slash = 0;
    else
        rel_dir[0] = 0;
    put_line_marker(out, 1, rel);
    long line_no = 0;
    for (const char *p = body; *p;) {
        const char *nl = strchr(p, '\n');
        size_t len = nl ? (size_t)(nl - p) : strlen(p);
        line_no++;
        char name[PATH_MAX], inc[PATH_MAX + 16];
        if (include_name(p, len, name, sizeof name) && resolve(rel_dir, name, inc, sizeof inc)) {
            int open = 0;
            for (int i = 0; i < x->depth; i++)
                open |= strcmp(x->stack[i], inc) == 0;
            /* A file already being expanded is skipped: its include guard would empty it anyway. */
            if (!open && expand_file(x, out, inc))
                return -1;
            put_line_marker(out, line_no + 1, rel);
        } else {
            /* Unresolved includes (system headers in host-only branches) stay for the preprocessor. */
            put(out, p, len);
            puts_(out, "\n");
        }
        p += len + (nl ? 1 : 0);
    }
    x->depth--;
    return 0;
}

static char *opencl_program_expand(const char *root, vx_err *e);

char *opencl_program_text(const vx_model *m, const char *defines, const char *kernel_file, vx_err *e)
{
    const char *source = vx_model_source(m);
    char rel[PATH_MAX];
    if (!resolve("", source, rel, sizeof rel)) {
        vx_fail(e, "model %s: its portable source %s is not among the sources embedded at build time (a header in a "
                   "folder of models/)",
                m->name, source);
        return NULL;
    }
    size_t size = strlen(defines) + strlen(source) + strlen(kernel_file) + 512;
    char *root = malloc(size);
    if (!root) {
        vx_fail(e, "out of memory assembling the OpenCL program");
        return NULL;
    }
    snprintf(root, size,
             "/* voxlab OpenCL program for model %s (assembled by tracer/backends/opencl/opencl_program.c) */\n"
             "%s"
             "#include \"prelude.h\"\n"
             "#include \"%s\"\n"
             "#include \"%s\"\n",
             m->name, defines, source, kernel_file);
    char *text = opencl_program_expand(root, e);
    free(root);
    return text;
}

/* A program text from `root`, its #include "..." lines expanded from the embedded sources and the
 * test hook applied. */
static char *opencl_program_expand(const char *root, vx_err *e)
{
    expander x = {.e = e};
    text out = {0};
    if (expand_text(&x, &out, root, "voxlab-program")) {
        free(out.s);
        return NULL;
    }
    const char *brk = getenv("VOXLAB_OPENCL_BREAK_KERNEL");
    if (brk && *brk)
        puts_(&out, "#line 1 \"VOXLAB_OPENCL_BREAK_KERNEL (test hook)\"\nthis is not OpenCL C;\n");
    if (out.failed) {
        free(out.s);
        vx_fail(e, "out of memory assembling the OpenCL program");
        return NULL;
    }
    return out.s;
}
