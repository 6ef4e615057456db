/* `voxlab compare A B [--json] [--heatmap OUT.png]`: MSE, PSNR and SSIM (as scikit-image defines
 * them, see metrics.c) between two images of the same size, e.g. a render and its ground truth. */
#ifndef VX_CMD_COMPARE_H
#define VX_CMD_COMPARE_H

#ifdef __cplusplus
extern "C" {
#endif

#include <stddef.h>

#include "metrics.h"

/* The object `compare --json` prints (without the newline), malloc'ed (NULL when out of memory);
 * provenance: the "provenance" member's JSON object text, or NULL for none. The Python API
 * (tracer/api/) returns the same text for arrays, which carry no provenance. */
char *compare_json(const image_metrics *m, int width, int height, const char *provenance);
/* The voxlab attributes of each EXR's header (without the prefix) as the JSON object
 * {"a": {...}, "b": {...}} in *text (malloc'ed), when either file has some; NULL otherwise. */
int compare_provenance_json(const char *const paths[2], char **text, vx_err *e);

/* argv[0] is "compare". Prints the result on stdout; errors go to stderr as
 * "voxlab compare: <message naming the file>". Returns 0 on success, 1 on any error. */
int cmd_compare(int argc, char **argv);

#ifdef __cplusplus
}
#endif

#endif
