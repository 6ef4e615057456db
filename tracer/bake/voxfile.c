#include "voxfile.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fileio.h"
#include "readfile.h"

static const char magic[8] = {'V', 'O', 'X', 'L', 'A', 'B', '\n', 0};

/* The header is written field by field (little-endian host assumed: x86-64, as the project's machines). */
typedef struct {
    char magic[8];
    voxfile_header h;
} disk_header;

static uint64_t fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ULL;
    return h;
}

int voxfile_write(const char *path, const voxfile_header *h, const void *records, vx_err *e)
{
    disk_header d;
    memset(&d, 0, sizeof d);
    memcpy(d.magic, magic, sizeof magic);
    d.h = *h;
    d.h.version = VOXFILE_VERSION;
    size_t bytes = (size_t)(h->voxel_bytes * h->record_count);
    uint64_t sum = fnv1a(fnv1a(0xcbf29ce484222325ULL, &d, sizeof d), records, bytes);
    char tmp[4096 + 64];
    FILE *f = fileio_open_temp(path, tmp, sizeof tmp, e);
    if (!f)
        return -1;
    if (fwrite(&d, sizeof d, 1, f) != 1 || (bytes && fwrite(records, bytes, 1, f) != 1) ||
        fwrite(&sum, sizeof sum, 1, f) != 1) {
        fileio_abort(f, tmp);
        return vx_fail(e, "%s: write failed: %s", path, strerror(errno));
    }
    return fileio_commit(f, tmp, path, e);
}

/* read() until n bytes or the end of the file; returns the bytes read, or -1 on an error. */
static long long read_full(int fd, void *buf, size_t n)
{
    size_t got = 0;
    while (got < n) {
        ssize_t r = read(fd, (char *)buf + got, n - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0)
            return -1;
        if (r == 0)
            break;
        got += (size_t)r;
    }
    return (long long)got;
}

int voxfile_read_header(const char *path, voxfile_header *h, vx_err *e)
{
    off_t size;
    int fd = readfile_open(path, ".vox file", UINT64_MAX, &size, e);
    if (fd < 0)
        return -1;
    disk_header d;
    long long got = read_full(fd, &d, sizeof d);
    close(fd);
    if (got != (long long)sizeof d || memcmp(d.magic, magic, sizeof magic) != 0)
        return vx_fail(e, "%s: not a voxlab .vox file (bad magic or too short)", path);
    *h = d.h;
    h->model[sizeof h->model - 1] = 0;
    h->params[sizeof h->params - 1] = 0;
    if (h->version != VOXFILE_VERSION)
        return vx_fail(e, "%s: .vox version %u, but this voxlab reads version %d: bake it again", path, h->version,
                       VOXFILE_VERSION);
    return 0;
}

int voxfile_read(const char *path, uint64_t scene_identity, voxfile_header *h, void **records, vx_err *e)
{
    *records = NULL;
    off_t size;
    int fd = readfile_open(path, ".vox file", UINT64_MAX, &size, e);
    if (fd < 0)
        return -1;
    disk_header d;
    if (read_full(fd, &d, sizeof d) != (long long)sizeof d || memcmp(d.magic, magic, sizeof magic) != 0) {
        close(fd);
        return vx_fail(e, "%s: not a voxlab .vox file (bad magic or too short)", path);
    }
    *h = d.h;
    if (h->version != VOXFILE_VERSION) {
        close(fd);
        return vx_fail(e, "%s: .vox version %u, but this voxlab reads version %d: bake it again", path, h->version,
                       VOXFILE_VERSION);
    }
    h->model[sizeof h->model - 1] = 0;
    h->params[sizeof h->params - 1] = 0;
    if (h->scene_identity != scene_identity) {
        close(fd);
        return vx_fail(e, "%s: baked from another scene (identity %016llx, this scene is %016llx): bake it again",
                       path, (unsigned long long)h->scene_identity, (unsigned long long)scene_identity);
    }
    /* Checked before the product is formed, so that a crafted header cannot overflow it. */
    if (h->voxel_bytes == 0 || h->voxel_bytes > 1 << 20 || h->record_count > (1ULL << 34)) {
        close(fd);
        return vx_fail(e, "%s: damaged header: %llu records of %llu bytes", path,
                       (unsigned long long)h->record_count, (unsigned long long)h->voxel_bytes);
    }
    uint64_t bytes = h->voxel_bytes * h->record_count;
    if ((uint64_t)size != sizeof d + bytes + sizeof(uint64_t)) {
        close(fd);
        return vx_fail(e, "%s: truncated or damaged: %lld bytes, the header promises %llu", path, (long long)size,
                       (unsigned long long)(sizeof d + bytes + sizeof(uint64_t)));
    }
    void *rec = malloc(bytes ? (size_t)bytes : 1);
    uint64_t stored;
    if (!rec || read_full(fd, rec, (size_t)bytes) != (long long)bytes ||
        read_full(fd, &stored, sizeof stored) != (long long)sizeof stored) {
        free(rec);
        close(fd);
        return vx_fail(e, "%s: cannot read the voxel records%s", path, rec ? "" : ": out of memory");
    }
    close(fd);
    if (fnv1a(fnv1a(0xcbf29ce484222325ULL, &d, sizeof d), rec, (size_t)bytes) != stored) {
        free(rec);
        return vx_fail(e, "%s: checksum mismatch: the file is damaged", path);
    }
    *records = rec;
    return 0;
}
