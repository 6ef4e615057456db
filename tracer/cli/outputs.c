/* Outputs that would overwrite an input or each other, refused before any work (outputs.h). */
#include "outputs.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

void outputs_add(outputs_list *l, const char *what, const char *path, int output)
{
    outputs_file *f = l->oom ? NULL : realloc(l->f, sizeof *f * (l->count + 1));
    if (!f) {
        l->oom = 1;
        return;
    }
    l->f = f;
    f[l->count] = (outputs_file){strdup(what), strdup(path), output};
    if (!f[l->count].what || !f[l->count].path) {
        free(f[l->count].what);
        free(f[l->count].path);
        l->oom = 1;
        return;
    }
    l->count++;
}

void outputs_add_scene(outputs_list *l, const scene *s)
{
    outputs_add(l, "the scene file", s->path, 0);
    for (int i = 0; i < s->input_count; i++) {
        char what[700];
        snprintf(what, sizeof what, "the scene's %s", s->input_fields[i]);
        outputs_add(l, what, s->inputs[i], 0);
    }
}

void outputs_add_frames(outputs_list *l, const char *out_path, const char *stats_path, const frame_range *fr)
{
    for (int f = fr->first; fr->sequence && f <= fr->last; f++) {
        char path[4096];
        frames_path(out_path, f, path, sizeof path);
        outputs_add(l, "-o", path, 1);
        if (stats_path) {
            frames_path(stats_path, f, path, sizeof path);
            outputs_add(l, "--stats", path, 1);
        }
    }
    if (!fr->sequence) {
        outputs_add(l, "-o", out_path, 1);
        if (stats_path)
            outputs_add(l, "--stats", stats_path, 1);
    }
}

/* Which file a path names: an existing file by device and inode (a symbolic or hard link to an
 * input is that input); a file not there yet by its directory's device and inode and its name, so
 * that out.exr and ./out.exr meet. A path whose directory cannot be read keeps its text. */
typedef struct {
    dev_t dev;
    ino_t ino;
    const char *name;
    size_t index;
} file_key;

static file_key key_of(const outputs_file *f, size_t index)
{
    file_key k = {0, 0, "", index};
    struct stat st;
    if (stat(f->path, &st) == 0) {
        k.dev = st.st_dev, k.ino = st.st_ino;
        return k;
    }
    const char *slash = strrchr(f->path, '/');
    char dir[4096];
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - f->path) : 1, slash ? f->path : ".");
    if (slash == f->path)
        snprintf(dir, sizeof dir, "/");
    k.name = f->path;
    if (stat(dir, &st) == 0)
        k.dev = st.st_dev, k.ino = st.st_ino, k.name = slash ? slash + 1 : f->path;
    return k;
}

static int key_order(const void *pa, const void *pb)
{
    const file_key *a = pa, *b = pb;
    if (a->dev != b->dev)
        return a->dev < b->dev ? -1 : 1;
    if (a->ino != b->ino)
        return a->ino < b->ino ? -1 : 1;
    int c = strcmp(a->name, b->name);
    return c ? c : a->index < b->index ? -1 : a->index > b->index;
}

static int same_file(const file_key *a, const file_key *b)
{
    return a->dev == b->dev && a->ino == b->ino && strcmp(a->name, b->name) == 0;
}

/* In group k[0..n) (one file), the output to refuse (the first given) and what it collides with:
 * an input when there is one, else the output given before it. */
static void group_clash(const outputs_list *l, const file_key *k, size_t n, size_t *out, size_t *with)
{
    size_t input = SIZE_MAX, first = SIZE_MAX, second = SIZE_MAX;
    for (size_t i = 0; i < n; i++) {
        size_t x = k[i].index;
        if (!l->f[x].output)
            input = input == SIZE_MAX ? x : input;
        else if (first == SIZE_MAX)
            first = x;
        else if (second == SIZE_MAX)
            second = x;
    }
    *out = *with = SIZE_MAX;
    if (first != SIZE_MAX && input != SIZE_MAX)
        *out = first, *with = input;
    else if (second != SIZE_MAX)
        *out = second, *with = first;
}

static int clash_message(const outputs_list *l, size_t out, size_t with, vx_err *e)
{
    const outputs_file *o = &l->f[out], *w = &l->f[with];
    if (w->output)
        return vx_fail(e, "%s %s is the same file as %s %s: refusing to write two outputs to one file", o->what,
                       o->path, w->what, w->path);
    int same_text = strcmp(o->path, w->path) == 0;
    return vx_fail(e, "%s %s is %s%s%s%s: refusing to overwrite an input", o->what, o->path, w->what,
                   same_text ? "" : " (", same_text ? "" : w->path, same_text ? "" : ")");
}

int outputs_check(const outputs_list *l, vx_err *e)
{
    if (l->oom)
        return vx_fail(e, "out of memory for the list of input and output files");
    file_key *k = malloc(sizeof *k * (l->count + 1));
    if (!k)
        return vx_fail(e, "out of memory for the list of input and output files");
    for (size_t i = 0; i < l->count; i++)
        k[i] = key_of(&l->f[i], i);
    /* Sorted, each file's names sit together: n log n, for sequences of many frames. */
    qsort(k, l->count, sizeof *k, key_order);
    size_t best_out = SIZE_MAX, best_with = SIZE_MAX;
    for (size_t i = 0, j; i < l->count; i = j) {
        for (j = i + 1; j < l->count && same_file(&k[i], &k[j]); j++)
            ;
        size_t out, with;
        group_clash(l, k + i, j - i, &out, &with);
        if (out < best_out) /* the clash of the output given first, whatever the files' order */
            best_out = out, best_with = with;
    }
    free(k);
    return best_out == SIZE_MAX ? 0 : clash_message(l, best_out, best_with, e);
}

void outputs_free(outputs_list *l)
{
    for (size_t i = 0; i < l->count; i++) {
        free(l->f[i].what);
        free(l->f[i].path);
    }
    free(l->f);
    memset(l, 0, sizeof *l);
}

int outputs_check_scene(const scene *s, const char *vox, const char *out_path, const char *stats_path,
                        const frame_range *fr, vx_err *e)
{
    outputs_list l = {0};
    outputs_add_scene(&l, s);
    if (vox)
        outputs_add(&l, "the --vox file", vox, 0);
    outputs_add_frames(&l, out_path, stats_path, fr);
    int rc = outputs_check(&l, e);
    outputs_free(&l);
    return rc;
}
