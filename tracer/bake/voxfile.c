#include "voxfile.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fileio.h"
#include "prefault.h"
#include "readfile.h"

static const char magic[8] = {'V', 'O', 'X', 'L', 'A', 'B', '\n', 0};

/* The header is written field by field (little-endian host assumed: x86-64, as the project's machines). */
typedef struct {
    char magic[8];
    voxfile_header h;
} disk_header;

/* The checksum (voxfile.h): FNV-1a over 64-bit little-endian words, fed in pieces. */
typedef struct {
    uint64_t h;
    unsigned char part[8]; /* bytes of a word not yet complete */
    size_t n;
} checksum;

#define FNV_PRIME 0x100000001b3ULL

static void checksum_add(checksum *c, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (; n && c->n; n--) {
        c->part[c->n++] = *p++;
        if (c->n == 8) {
            uint64_t w;
            memcpy(&w, c->part, 8);
            c->h = (c->h ^ w) * FNV_PRIME;
            c->n = 0;
        }
    }
    for (; n >= 8; n -= 8, p += 8) {
        uint64_t w;
        memcpy(&w, p, 8);
        c->h = (c->h ^ w) * FNV_PRIME;
    }
    for (; n; n--)
        c->part[c->n++] = *p++;
}

static uint64_t checksum_end(checksum *c)
{
    if (c->n) {
        memset(c->part + c->n, 0, 8 - c->n);
        uint64_t w;
        memcpy(&w, c->part, 8);
        c->h = (c->h ^ w) * FNV_PRIME;
        c->n = 0;
    }
    return c->h;
}

uint64_t voxfile_checksum(const void *data, size_t n)
{
    checksum c = {.h = 0xcbf29ce484222325ULL};
    checksum_add(&c, data, n);
    return checksum_end(&c);
}

/* The checksum of the three parts of a file, as if they were one block. */
static uint64_t file_checksum(const void *header, size_t header_bytes, const void *records, size_t bytes,
                              const void *cells, size_t cell_bytes)
{
    checksum c = {.h = 0xcbf29ce484222325ULL};
    checksum_add(&c, header, header_bytes);
    checksum_add(&c, records, bytes);
    checksum_add(&c, cells, cell_bytes);
    return checksum_end(&c);
}

int voxfile_write(const char *path, const voxfile_header *h, const void *records, const uint32_t *cells, vx_err *e)
{
    disk_header d;
    memset(&d, 0, sizeof d);
    memcpy(d.magic, magic, sizeof magic);
    d.h = *h;
    d.h.version = VOXFILE_VERSION;
    size_t bytes = (size_t)(h->voxel_bytes * h->record_count), cell_bytes = (size_t)h->voxels * sizeof *cells;
    uint64_t sum = file_checksum(&d, sizeof d, records, bytes, cells, cell_bytes);
    char tmp[4096 + 64];
    FILE *f = fileio_open_temp(path, tmp, sizeof tmp, e);
    if (!f)
        return -1;
    if (fwrite(&d, sizeof d, 1, f) != 1 || (bytes && fwrite(records, bytes, 1, f) != 1) ||
        (cell_bytes && fwrite(cells, cell_bytes, 1, f) != 1) || fwrite(&sum, sizeof sum, 1, f) != 1) {
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

/* Whether the header's counts are sane and the file's size is what they promise. Checked before the
 * products are formed, so that a crafted header cannot overflow them (1024^3 cells at most); and by
 * voxfile_read_header too, so that a damaged count is called damaged, naming the file, before
 * `render --vox` estimates its memory from it (a record count of 2^31 was refused as "needs about
 * 80 GiB ... lower --res, --size or --rays", the bad-input audit). */
static int header_fits_file(const char *path, const voxfile_header *h, off_t size, vx_err *e)
{
    if (h->voxel_bytes == 0 || h->voxel_bytes > 1 << 20 || h->record_count > (1ULL << 34) || h->voxels > (1ULL << 30))
        return vx_fail(e, "%s: damaged header: %llu records of %llu bytes for %llu voxels", path,
                       (unsigned long long)h->record_count, (unsigned long long)h->voxel_bytes,
                       (unsigned long long)h->voxels);
    uint64_t expected = sizeof(disk_header) + h->voxel_bytes * h->record_count + h->voxels * sizeof(uint32_t) +
                        sizeof(uint64_t);
    if ((uint64_t)size != expected)
        return vx_fail(e, "%s: truncated or damaged: %lld bytes, the header promises %llu", path, (long long)size,
                       (unsigned long long)expected);
    return 0;
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
    return header_fits_file(path, h, size, e);
}

int voxfile_read(const char *path, uint64_t scene_identity, voxfile_header *h, void **records, uint32_t **cells,
                 vx_err *e)
{
    *records = NULL;
    *cells = NULL;
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
    if (header_fits_file(path, h, size, e)) {
        close(fd);
        return -1;
    }
    uint64_t bytes = h->voxel_bytes * h->record_count, cell_bytes = h->voxels * sizeof **cells;
    void *rec = malloc(bytes ? (size_t)bytes : 1);
    uint32_t *cel = malloc(cell_bytes ? (size_t)cell_bytes : 1);
    vx_populate(rec, (size_t)bytes); /* mapped in one call, not faulted in by read() page by page */
    vx_populate(cel, (size_t)cell_bytes);
    uint64_t stored;
    if (!rec || !cel || read_full(fd, rec, (size_t)bytes) != (long long)bytes ||
        read_full(fd, cel, (size_t)cell_bytes) != (long long)cell_bytes ||
        read_full(fd, &stored, sizeof stored) != (long long)sizeof stored) {
        int oom = !rec || !cel;
        free(rec);
        free(cel);
        close(fd);
        return vx_fail(e, "%s: cannot read the voxel records%s", path, oom ? ": out of memory" : "");
    }
    close(fd);
    if (file_checksum(&d, sizeof d, rec, (size_t)bytes, cel, (size_t)cell_bytes) != stored) {
        free(rec);
        free(cel);
        return vx_fail(e, "%s: checksum mismatch: the file is damaged", path);
    }
    *records = rec;
    *cells = cel;
    return 0;
}
