/* Baked model data on disk (.vox): a versioned header naming the model, the scene's identity and the
 * grid, the records, the grid's non-empty level-0 cells, and a checksum over everything before it
 * (voxfile_checksum). Loading a file of another version,
 * scene or model, or a damaged one, is a clear error. */
#ifndef VX_VOXFILE_H
#define VX_VOXFILE_H

#include <stddef.h>
#include <stdint.h>

#include "error.h"

/* Version 2: no bake timing in the header, so that a file is a pure function of its inputs (the
 * same scene, model, resolution, rays and seed give the same bytes); timings are in --stats.
 * Version 3: the model's record layout version (checked on load, so that records of an older
 * layout of the same size are refused rather than misread) and the model parameters of the bake.
 * Version 4: after the records, the grid's level-0 cells (voxels x uint32, packed x << 20 | y << 10 | z
 * in dense-index order, grid_level.coords), so that a render rebuilds the grid from them
 * (grid_build_sorted_cells) instead of voxelising the scene again. The header is unchanged. The
 * checksum became FNV-1a over 64-bit words (it was over bytes: a chain of one multiply per byte
 * took 0.1 s of a 1024^3 render's load). */
#define VOXFILE_VERSION 4

typedef struct {
    uint32_t version;
    char model[32];
    uint64_t scene_identity;
    int32_t n;            /* grid cells per side */
    int32_t rays;         /* sample rays per voxel */
    uint64_t seed;
    uint64_t voxel_bytes; /* one record */
    uint64_t record_count;
    uint64_t voxels;      /* non-empty level-0 voxels: the cells stored after the records */
    uint32_t layout_version; /* the model's record.layout_version */
    uint32_t reserved;       /* 0 */
    char params[256];        /* the model's parameters, bake_params_format's text (NUL-terminated) */
} voxfile_header;

/* The file's checksum of its first n bytes (everything but the checksum): FNV-1a (offset basis
 * 0xcbf29ce484222325, prime 0x100000001b3) over the bytes taken as 64-bit little-endian words, the
 * last one completed with zero bytes. Guards against accidents, not against crafted files. */
uint64_t voxfile_checksum(const void *data, size_t n);
/* cells: the grid's h->voxels level-0 cells (grid_level.coords). */
int voxfile_write(const char *path, const voxfile_header *h, const void *records, const uint32_t *cells, vx_err *e);
/* Reads and verifies a file (a regular file only); *records and *cells (h->voxels entries, in the
 * order written, not yet checked against a grid) are malloc'ed, both NULL on failure.
 * scene_identity must match the header's. The records' contents are the model's to validate
 * (tracer/bake/record_check.h). */
int voxfile_read(const char *path, uint64_t scene_identity, voxfile_header *h, void **records, uint32_t **cells,
                 vx_err *e);
/* The header alone (magic and version checked, nothing else): what --dry-run estimates from. */
int voxfile_read_header(const char *path, voxfile_header *h, vx_err *e);

#endif
