#include "voxfile.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fileio.h"

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

int voxfile_read(const char *path, uint64_t scene_identity, voxfile_header *h, void **records, vx_err *e)
{
    *records = NULL;
    FILE *f = fopen(path, "rb");
    if (!f)
        return vx_fail(e, "%s: cannot open: %s", path, strerror(errno));
    disk_header d;
    if (fread(&d, sizeof d, 1, f) != 1 || memcmp(d.magic, magic, sizeof magic) != 0) {
        fclose(f);
        return vx_fail(e, "%s: not a voxlab .vox file (bad magic or too short)", path);
    }
    *h = d.h;
    if (h->version != VOXFILE_VERSION) {
        fclose(f);
        return vx_fail(e, "%s: .vox version %u, but this voxlab reads version %d: bake it again", path, h->version,
                       VOXFILE_VERSION);
    }
    h->model[sizeof h->model - 1] = 0;
    if (h->scene_identity != scene_identity) {
        fclose(f);
        return vx_fail(e, "%s: baked from another scene (identity %016llx, this scene is %016llx): bake it again",
                       path, (unsigned long long)h->scene_identity, (unsigned long long)scene_identity);
    }
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, (long)sizeof d, SEEK_SET);
    uint64_t bytes = h->voxel_bytes * h->record_count;
    if (h->voxel_bytes == 0 || h->voxel_bytes > 1 << 20 || h->record_count > (1ULL << 34) ||
        (uint64_t)size != sizeof d + bytes + sizeof(uint64_t)) {
        fclose(f);
        return vx_fail(e, "%s: truncated or damaged: %ld bytes, the header promises %llu", path, size,
                       (unsigned long long)(sizeof d + bytes + sizeof(uint64_t)));
    }
    void *rec = malloc(bytes ? (size_t)bytes : 1);
    uint64_t stored;
    if (!rec || (bytes && fread(rec, (size_t)bytes, 1, f) != 1) || fread(&stored, sizeof stored, 1, f) != 1) {
        free(rec);
        fclose(f);
        return vx_fail(e, "%s: cannot read the voxel records", path);
    }
    fclose(f);
    if (fnv1a(fnv1a(0xcbf29ce484222325ULL, &d, sizeof d), rec, (size_t)bytes) != stored) {
        free(rec);
        return vx_fail(e, "%s: checksum mismatch: the file is damaged", path);
    }
    *records = rec;
    return 0;
}
