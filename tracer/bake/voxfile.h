/* Baked model data on disk (.vox): a versioned header naming the model, the scene's identity and the
 * grid, the records, and a checksum over everything before it. Loading a file of another version,
 * scene or model, or a damaged one, is a clear error. */
#ifndef VX_VOXFILE_H
#define VX_VOXFILE_H

#include <stddef.h>
#include <stdint.h>

#include "error.h"

/* Version 2: no bake timing in the header, so that a file is a pure function of its inputs (the
 * same scene, model, resolution, rays and seed give the same bytes); timings are in --stats.
 * Version 3: the model's record layout version (checked on load, so that records of an older
 * layout of the same size are refused rather than misread) and the model parameters of the bake. */
#define VOXFILE_VERSION 3

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
    uint32_t layout_version; /* the model's record.layout_version */
    uint32_t reserved;       /* 0 */
    char params[256];        /* the model's parameters, bake_params_format's text (NUL-terminated) */
} voxfile_header;

int voxfile_write(const char *path, const voxfile_header *h, const void *records, vx_err *e);
/* Reads and verifies a file (a regular file only); *records is malloc'ed, NULL on failure.
 * scene_identity must match the header's. The records' contents are the model's to validate
 * (tracer/bake/record_check.h). */
int voxfile_read(const char *path, uint64_t scene_identity, voxfile_header *h, void **records, vx_err *e);
/* The header alone (magic and version checked, nothing else): what --dry-run estimates from. */
int voxfile_read_header(const char *path, voxfile_header *h, vx_err *e);

#endif
