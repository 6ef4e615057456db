/* The C core as a shared library (build/libvoxlab.so, `make pylib`) for the Python package
 * experiments/voxlab/ (ctypes): the commands truth, bake, render and compare in-process, with no
 * file written. Plain functions with flat arguments, so that ctypes needs no struct layouts:
 *
 *  - every call returns 0, or -1 with the message the CLI would print (after "voxlab CMD: ") in
 *    err[err_size];
 *  - images come back as malloc'ed float RGB, row 0 at the top (*pixels, *width, *height), and
 *    statistics as the JSON text `--stats` writes (*stats); both are freed with vxapi_free;
 *  - a scene is loaded once (vxapi_scene_load: a file, or JSON text whose relative paths resolve
 *    against base_dir) and a bake is kept in memory (vxapi_bake_*), each freed by its own call. */
#ifndef VX_VOXLAB_API_H
#define VX_VOXLAB_API_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vxapi_scene vxapi_scene;
typedef struct vxapi_bake vxapi_bake;

/* path: a scene file; or json: the scene's JSON text, path then NULL and base_dir the folder its
 * relative paths are relative to (NULL: the current directory). NULL on failure. */
vxapi_scene *vxapi_scene_load(const char *path, const char *json, const char *base_dir, char *err, size_t err_size);
void vxapi_scene_free(vxapi_scene *s);
/* The scene's default image size. */
void vxapi_scene_size(const vxapi_scene *s, int *width, int *height);

/* `voxlab truth`: width/height 0 = the scene's; threads 0 = every core; shadows "march" or "slicemap"
 * (NULL: the scene's method), shadow_res its --shadow-res (0: the default). */
int vxapi_truth(const vxapi_scene *s, int width, int height, int spp, long long seed, int threads, const char *shadows,
                int shadow_res, float **pixels, int *out_width, int *out_height, char **stats, char *err,
                size_t err_size);

/* `voxlab bake` kept in memory: params are "name=value" strings (n_params of them). NULL on failure. */
vxapi_bake *vxapi_bake_run(const vxapi_scene *s, const char *model, int res, int rays, long long seed, int threads,
                           const char *const *params, int n_params, char **stats, char *err, size_t err_size);
/* A .vox file read and validated for scene s as `render --vox` does (model NULL: the file's). */
vxapi_bake *vxapi_bake_load(const vxapi_scene *s, const char *vox_path, const char *model, char *err,
                            size_t err_size);
/* Writes the bake as a .vox file (atomically), the bytes `voxlab bake` writes. */
int vxapi_bake_save(const vxapi_bake *b, const char *vox_path, char *err, size_t err_size);
void vxapi_bake_free(vxapi_bake *b);

/* `voxlab render` of a bake (from vxapi_bake_run or vxapi_bake_load, for the same scene): seed is
 * the render's; backend "c" or "opencl" (NULL: "c"); shadows "march", "slicemap", "slicemap-model" or
 * "voxel" (NULL: the scene's method), shadow_res its --shadow-res (0: the default). Precomputed
 * shadow maps stay cached in the process (tracer/shadows/shadow_cache.c); voxel's are built per render. */
int vxapi_render(const vxapi_scene *s, const vxapi_bake *b, int width, int height, int spp, long long seed,
                 int threads, int cache, int shadow_skip, const char *backend, const char *shadows, int shadow_res,
                 float **pixels, int *out_width, int *out_height, char **stats, char *err, size_t err_size);

/* Reads an image file as float (channels as stored, 1-4) like `voxlab compare` does. */
int vxapi_image_read(const char *path, float **pixels, int *width, int *height, int *channels, char *err,
                     size_t err_size);
/* `voxlab compare`'s metrics of b against reference a (both width x height x channels floats): the
 * JSON object `compare --json` prints, in *json. */
int vxapi_compare(const float *a, const float *b, int width, int height, int channels, char **json, char *err,
                  size_t err_size);

/* `voxlab compare A B --json` of two image files, provenance (their EXR headers') included. */
int vxapi_compare_files(const char *path_a, const char *path_b, char **json, char *err, size_t err_size);

/* The registered models, one name a line, in *names. */
int vxapi_models(char **names);
void vxapi_free(void *p);

#ifdef __cplusplus
}
#endif

#endif
