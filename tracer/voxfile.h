/* Baked model data on disk (.vox): a versioned header naming the model, the scene's identity and the
 * grid, the records, and a checksum over everything before it. Loading a file of another version,
 * scene or model, or a damaged one, is a clear error. */
#ifndef VX_VOXFILE_H
#define VX_VOXFILE_H

#include <stddef.h>
#include <stdint.h>

#include "error.h"

#define VOXFILE_VERSION 1

typedef struct {
    uint32_t version;
    char model[32];
    uint64_t scene_identity;
    int32_t n;            /* grid cells per side */
    int32_t rays;         /* sample rays per voxel */
    uint64_t seed;
    uint64_t voxel_bytes; /* one record */
    uint64_t record_count;
    uint64_t voxels;      /* non-empty level-0 voxels (checked against the rebuilt grid) */
    double bake_seconds;
} voxfile_header;

int voxfile_write(const char *path, const voxfile_header *h, const void *records, vx_err *e);
/* Reads and verifies a file; *records is malloc'ed. scene_identity must match the header's. */
int voxfile_read(const char *path, uint64_t scene_identity, voxfile_header *h, void **records, vx_err *e);

#endif
