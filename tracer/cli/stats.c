/* The --stats JSON every command writes: the scene's fields, the image's, the bake's, and writing
 * the object atomically. Shared by the commands, so no command's file depends on another's. */
#include "stats.h"

#include "scene_tris.h"

#include "instancing.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "commands.h"
#include "fileio.h"
#include "parallel.h"

/* The high-water mark of this process's own memory (VmHWM). Not getrusage's ru_maxrss: Linux
 * folds into it the RSS of the image exec replaced, so a voxlab started by a 150 MB Python
 * experiment reported 150 MB whatever it used itself. */
double peak_rss_bytes(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    double kb = -1;
    while (f && fgets(line, sizeof line, f))
        if (strncmp(line, "VmHWM:", 6) == 0) {
            kb = strtod(line + 6, NULL);
            break;
        }
    if (f)
        fclose(f);
    if (kb >= 0)
        return kb * 1024.0;
    struct rusage ru; /* no procfs: the best the system offers */
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_maxrss * 1024.0; /* Linux reports kilobytes */
}

cJSON *stats_scene_fields(const scene *s)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "scene", s->name);
    cJSON_AddNumberToObject(j, "triangles", (double)scene_triangle_count(s));
    cJSON_AddNumberToObject(j, "degenerate_triangles", (double)s->degenerate_triangles);
    /* Instancing (instancing.h): "triangles" counts every copy; the prototypes' own triangles are
     * what the truth's BVH holds. */
    size_t protos = 0;
    for (int i = 0; s->inst && i < s->inst->proto_count; i++)
        protos += s->inst->protos[i].triangle_count;
    cJSON_AddNumberToObject(j, "instances", s->inst ? (double)s->inst->count : 0.0);
    cJSON_AddNumberToObject(j, "prototype_triangles", (double)protos);
    cJSON *fx = cJSON_AddArrayToObject(j, "effects");
    for (unsigned bit = 1; bit <= EFFECT_TEXTURES; bit <<= 1)
        if (s->effects & bit)
            cJSON_AddItemToArray(fx, cJSON_CreateString(effect_name(bit)));
    return j;
}

/* The bytes of one mesh's arrays: per vertex a position, a normal, a uv and a colour; per triangle
 * three indices and a material. */
static double mesh_array_bytes(const mesh *m)
{
    return (double)m->vertex_count * (3 + 3 + 2 + 3) * sizeof(float) +
           (double)m->triangle_count * (3 + 1) * sizeof(uint32_t);
}

/* What the truth traces and shades from besides its BVH: the scene's meshes (the instanced
 * prototypes and one placement per copy too) and its image textures' texels. Experiments charge the
 * truth this plus bvh_bytes, as they charge a model its records and grid (issue 15's audit: the
 * truth was charged its peak resident memory, image buffers and thread stacks included). */
static double scene_mesh_bytes(const scene *s)
{
    double b = mesh_array_bytes(&s->mesh);
    for (int i = 0; s->inst && i < s->inst->proto_count; i++)
        b += mesh_array_bytes(&s->inst->protos[i]);
    if (s->inst)
        b += (double)s->inst->count * sizeof(inst_instance);
    for (int i = 0; i < s->texture_count; i++)
        if (s->textures[i].kind == TEXTURE_IMAGE && s->textures[i].rgb)
            b += (double)s->textures[i].width * s->textures[i].height * 3 * sizeof(float);
    return b;
}

cJSON *stats_truth(const scene *s, const truth_options *o, const truth_counts *c)
{
    cJSON *j = stats_scene_fields(s);
    cJSON_AddStringToObject(j, "command", "truth");
    cJSON_AddNumberToObject(j, "mesh_bytes", scene_mesh_bytes(s));
    cJSON_AddNumberToObject(j, "seconds", c->seconds);
    cJSON_AddNumberToObject(j, "rays", (double)(c->primary_rays + c->shadow_rays));
    cJSON_AddNumberToObject(j, "primary_rays", (double)c->primary_rays);
    cJSON_AddNumberToObject(j, "shadow_rays", (double)c->shadow_rays);
    cJSON_AddNumberToObject(j, "truth_page_faults", (double)c->page_faults);
    stats_add_shadows(j, &c->shadows);
    cJSON_AddNumberToObject(j, "voxels", 0);
    cJSON_AddNumberToObject(j, "bytes_per_voxel", 0);
    stats_add_image(j, o->spp, o->width, o->height, o->seed, o->threads);
    return j;
}

void stats_add_shadows(cJSON *j, const shadow_stats *st)
{
    if (st->method < 0) { /* the scene declares no shadows: nothing was computed */
        cJSON_AddNullToObject(j, "shadow_method");
        cJSON_AddNullToObject(j, "shadow_res");
    } else {
        cJSON_AddStringToObject(j, "shadow_method", shadow_method_name(st->method));
        if (st->method == SHADOW_MARCH || st->method == SHADOW_VOXEL) /* no columns */
            cJSON_AddNullToObject(j, "shadow_res");
        else
            cJSON_AddNumberToObject(j, "shadow_res", st->res);
    }
    cJSON_AddNumberToObject(j, "shadow_build_seconds", st->build_seconds);
    cJSON_AddNumberToObject(j, "shadow_bytes", (double)st->bytes);
    cJSON_AddNumberToObject(j, "shadow_queries", (double)st->queries);
    cJSON_AddBoolToObject(j, "shadow_cache_hit", st->cache_hit);
}

void stats_add_image(cJSON *j, int spp, int width, int height, uint64_t seed, int threads)
{
    cJSON_AddNumberToObject(j, "spp", spp);
    cJSON_AddNumberToObject(j, "width", width);
    cJSON_AddNumberToObject(j, "height", height);
    cJSON_AddNumberToObject(j, "seed", (double)seed);
    cJSON_AddNumberToObject(j, "threads", parallel_threads(threads));
    cJSON_AddNumberToObject(j, "peak_rss_bytes", peak_rss_bytes());
}

int stats_finish(cJSON *j, const char *path, const char *cmd, const char *output)
{
    char *text = cJSON_Print(j);
    cJSON_Delete(j);
    vx_err e;
    int rc = -1;
    size_t n = text ? strlen(text) : 0;
    char *line = text ? realloc(text, n + 2) : NULL;
    if (!line) {
        free(text);
        snprintf(e.msg, sizeof e.msg, "%s: out of memory for the statistics", path);
    } else {
        line[n] = '\n', line[n + 1] = 0;
        rc = fileio_write_text(path, line, &e);
        free(line);
    }
    if (rc) {
        fprintf(stderr, "voxlab %s: --stats %s\n", cmd, e.msg);
        remove(output);
    }
    return rc;
}

void stats_add_backend(cJSON *j, const char *name, const backend_counts *bc)
{
    char key[96];
    snprintf(key, sizeof key, "%s_compile_seconds", name);
    cJSON_AddNumberToObject(j, key, bc->compile_seconds);
    snprintf(key, sizeof key, "%s_kernel_seconds", name);
    cJSON_AddNumberToObject(j, key, bc->kernel_seconds);
    snprintf(key, sizeof key, "%s_kernel_cpu_seconds", name);
    cJSON_AddNumberToObject(j, key, bc->kernel_cpu_seconds);
    snprintf(key, sizeof key, "%s_device", name);
    cJSON_AddStringToObject(j, key, bc->device);
    snprintf(key, sizeof key, "%s_compute_units", name);
    cJSON_AddNumberToObject(j, key, bc->compute_units);
    snprintf(key, sizeof key, "%s_wide_launch", name);
    cJSON_AddBoolToObject(j, key, bc->wide_launch);
}

void provenance_common(image_meta *m, int argc, char **argv, const scene *s, int width, int height, int spp,
                       uint64_t seed)
{
    memset(m, 0, sizeof *m);
    image_meta_add(m, "commit", "%s", voxlab_version());
    image_meta_add_command(m, argc, argv);
    image_meta_add(m, "scene", "%s", s->name);
    image_meta_add(m, "scene_hash", "%016llx", (unsigned long long)s->identity);
    image_meta_add(m, "size", "%dx%d", width, height);
    image_meta_add(m, "spp", "%d", spp);
    image_meta_add(m, "seed", "%llu", (unsigned long long)seed);
}
