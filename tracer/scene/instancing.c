/* Instancing (instancing.h; format in README.md): parsing the "instances" list and the seeded
 * "scatter", and keeping each copy's placement beside its prototype. */
#include "instancing.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json_util.h"
#include "rng.h"
#include "xform.h"

static scene_instancing *get(scene *s, const char *where, vx_err *e)
{
    if (!s->inst && !(s->inst = calloc(1, sizeof *s->inst)))
        vx_fail(e, "%s: out of memory", where);
    return s->inst;
}

/* The mesh's vertices from v0 and triangles from t0, as a mesh of their own (indices from 0). */
static int extract(const mesh *m, size_t v0, size_t t0, mesh *out)
{
    memset(out, 0, sizeof *out);
    for (size_t v = v0; v < m->vertex_count; v++) {
        const float *p = m->positions + 3 * v, *n = m->normals + 3 * v, *c = m->colors + 3 * v;
        uint32_t i = mesh_add_vertex(out, v3(p[0], p[1], p[2]), v3(n[0], n[1], n[2]), m->uvs[2 * v], m->uvs[2 * v + 1]);
        mesh_set_vertex_color(out, i, v3(c[0], c[1], c[2]));
    }
    for (size_t t = t0; t < m->triangle_count; t++) {
        const uint32_t *x = m->indices + 3 * t;
        if (x[0] < v0 || x[1] < v0 || x[2] < v0) /* a generator never points before its own vertices */
            return -1;
        mesh_add_triangle(out, x[0] - (uint32_t)v0, x[1] - (uint32_t)v0, x[2] - (uint32_t)v0, m->materials[t]);
    }
    return 0;
}

/* "instances": [{"translate", "rotate_deg", "scale"}, ...] */
static int parse_list(const cJSON *list, const char *where, xform **out, int *count, vx_err *e)
{
    int n = cJSON_IsArray(list) ? cJSON_GetArraySize(list) : 0;
    if (n < 1)
        return vx_fail(e, "%s.instances: expected a non-empty array of {\"translate\", \"rotate_deg\", \"scale\"}", where);
    if (n > INST_MAX_COUNT)
        return vx_fail(e, "%s.instances: %d instances, more than %d", where, n, INST_MAX_COUNT);
    if (!(*out = calloc((size_t)n, sizeof **out)))
        return vx_fail(e, "%s.instances: out of memory", where);
    const cJSON *it;
    int i = 0;
    cJSON_ArrayForEach(it, list)
    {
        char w[700];
        snprintf(w, sizeof w, "%s.instances[%d]", where, i);
        if (xform_parse(it, w, &(*out)[i], e))
            return -1;
        i++;
    }
    *count = n;
    return 0;
}

/* Up-facing triangles of [t0, t1) (geometric normal with y > 0) with their cumulative areas. */
static int surface_cdf(const mesh *m, size_t t0, size_t t1, size_t **tri, double **cdf, size_t *n)
{
    *n = 0;
    *tri = malloc((t1 - t0 + 1) * sizeof **tri);
    *cdf = malloc((t1 - t0 + 1) * sizeof **cdf);
    if (!*tri || !*cdf)
        return -1;
    double sum = 0;
    for (size_t t = t0; t < t1; t++) {
        const uint32_t *x = m->indices + 3 * t;
        vec3 a = mesh_position(m, x[0]), b = mesh_position(m, x[1]), c = mesh_position(m, x[2]);
        vec3 ng = v3_cross(v3_sub(b, a), v3_sub(c, a));
        double area = 0.5 * sqrt((double)ng.x * ng.x + (double)ng.y * ng.y + (double)ng.z * ng.z);
        if (!(ng.y > 0.0f) || !(area > 0.0) || !isfinite(area))
            continue;
        sum += area;
        (*tri)[*n] = t;
        (*cdf)[(*n)++] = sum;
    }
    return 0;
}

/* A point of the sampled surface: a triangle by area, then uniform inside it. */
static vec3 surface_point(const mesh *m, const size_t *tri, const double *cdf, size_t n, rng *r)
{
    double pick = rng_double(r) * cdf[n - 1];
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (cdf[mid] > pick)
            hi = mid;
        else
            lo = mid + 1;
    }
    const uint32_t *x = m->indices + 3 * tri[lo];
    vec3 a = mesh_position(m, x[0]), b = mesh_position(m, x[1]), c = mesh_position(m, x[2]);
    double su = sqrt(rng_double(r)), v = rng_double(r);
    double wa = 1 - su, wb = su * (1 - v), wc = su * v;
    return v3((float)(wa * a.x + wb * b.x + wc * c.x), (float)(wa * a.y + wb * b.y + wc * c.y),
              (float)(wa * a.z + wb * b.z + wc * c.z));
}

/* "scatter": {"count", "seed", "over": name | {"rect": [x0, z0, x1, z1], "y": h}, "scale_range": [a, b],
 * "rotate_y": bool}. Instance i draws from its own stream (seed, i): the first k instances of a
 * scatter do not change when the count grows. */
static int parse_scatter(const scene *s, const cJSON *sc, const char *where, xform **out, int *count, vx_err *e)
{
    char w[700];
    snprintf(w, sizeof w, "%s.scatter", where);
    static const char *const known[] = {"count", "seed", "over", "scale_range", "rotate_y", NULL};
    if (!cJSON_IsObject(sc))
        return vx_fail(e, "%s: expected an object {\"count\", \"seed\", \"over\", \"scale_range\", \"rotate_y\"}", w);
    if (json_only_fields(sc, w, known, e))
        return -1;
    int n = 0, rotate_y = 1;
    uint64_t seed = 1;
    if (!cJSON_GetObjectItemCaseSensitive(sc, "count"))
        return vx_fail(e, "%s: missing field \"count\" (the number of instances)", w);
    if (json_int_in(sc, "count", w, 1, INST_MAX_COUNT, &n, e) || json_u64(sc, "seed", w, &seed, e) ||
        json_bool(sc, "rotate_y", w, &rotate_y, e))
        return -1;
    double smin = 1, smax = 1;
    const cJSON *sr = cJSON_GetObjectItemCaseSensitive(sc, "scale_range");
    if (sr) {
        const cJSON *a = cJSON_GetArrayItem(sr, 0), *b = cJSON_GetArrayItem(sr, 1);
        if (!cJSON_IsArray(sr) || cJSON_GetArraySize(sr) != 2 || !cJSON_IsNumber(a) || !cJSON_IsNumber(b) ||
            !(a->valuedouble > 0) || !(b->valuedouble >= a->valuedouble) || !(b->valuedouble <= 1e6))
            return vx_fail(e, "%s.scale_range: expected [min, max] with 0 < min <= max <= 1e6", w);
        smin = a->valuedouble, smax = b->valuedouble;
    }
    const cJSON *over = cJSON_GetObjectItemCaseSensitive(sc, "over");
    const mesh *m = &s->mesh;
    size_t *tri = NULL, nt = 0;
    double *cdf = NULL, rect[4] = {0}, y = 0;
    if (cJSON_IsString(over)) {
        const inst_named *o = NULL;
        for (int i = 0; s->inst && i < s->inst->named_count; i++)
            if (strcmp(s->inst->named[i].name, over->valuestring) == 0)
                o = &s->inst->named[i];
        if (!o)
            return vx_fail(e, "%s.over: no earlier object is named \"%s\" (give that object \"name\": \"%s\")", w,
                           over->valuestring, over->valuestring);
        if (o->animated)
            return vx_fail(e, "%s.over: object \"%s\" is animated: instances scattered over it would not follow it", w,
                           over->valuestring);
        if (o->instanced)
            return vx_fail(e, "%s.over: object \"%s\" is instanced: scatter over an object drawn once", w,
                           over->valuestring);
        if (surface_cdf(m, o->t0, o->t1, &tri, &cdf, &nt)) {
            free(tri), free(cdf);
            return vx_fail(e, "%s: out of memory", w);
        }
        if (nt == 0) {
            free(tri), free(cdf);
            return vx_fail(e, "%s.over: object \"%s\" has no up-facing surface (+y) to scatter over", w, over->valuestring);
        }
    } else if (cJSON_IsObject(over)) {
        char wo[760];
        snprintf(wo, sizeof wo, "%s.over", w);
        static const char *const oknown[] = {"rect", "y", NULL};
        const cJSON *r = cJSON_GetObjectItemCaseSensitive(over, "rect");
        if (json_only_fields(over, wo, oknown, e) || json_number(over, "y", wo, &y, e))
            return -1;
        if (!cJSON_IsArray(r) || cJSON_GetArraySize(r) != 4)
            return vx_fail(e, "%s.rect: expected [x0, z0, x1, z1] (a rectangle of the plane y)", wo);
        for (int k = 0; k < 4; k++) {
            const cJSON *c = cJSON_GetArrayItem(r, k);
            if (!cJSON_IsNumber(c) || !(fabs(c->valuedouble) <= 1e18))
                return vx_fail(e, "%s.rect[%d]: expected a finite number within +-1e18", wo, k);
            rect[k] = c->valuedouble;
        }
        if (!(fabs(y) <= 1e18))
            return vx_fail(e, "%s.y: expected a finite number within +-1e18", wo);
    } else {
        return vx_fail(e, "%s.over: expected the name of an earlier object or {\"rect\": [x0, z0, x1, z1], \"y\": h}", w);
    }
    if (!(*out = calloc((size_t)n, sizeof **out))) {
        free(tri), free(cdf);
        return vx_fail(e, "%s: out of memory", w);
    }
    for (int i = 0; i < n; i++) {
        rng r = rng_seed(seed, (uint64_t)i);
        vec3 p = tri ? surface_point(m, tri, cdf, nt, &r)
                     : v3((float)(rect[0] + rng_double(&r) * (rect[2] - rect[0])), (float)y,
                          (float)(rect[1] + rng_double(&r) * (rect[3] - rect[1])));
        float k = (float)(smin + rng_double(&r) * (smax - smin));
        float ang = rotate_y ? (float)(360.0 * rng_double(&r)) : 0.0f;
        (*out)[i] = (xform){v3(k, k, k), v3(0, ang, 0), p};
    }
    free(tri), free(cdf);
    *count = n;
    return 0;
}

static int add_name(scene *s, const char *name, size_t t0, int animated, int instanced, const char *where, vx_err *e)
{
    scene_instancing *in = get(s, where, e);
    if (!in)
        return -1;
    for (int i = 0; i < in->named_count; i++)
        if (strcmp(in->named[i].name, name) == 0)
            return vx_fail(e, "%s.name: \"%s\" names an earlier object too", where, name);
    inst_named *g = realloc(in->named, (size_t)(in->named_count + 1) * sizeof *g);
    if (!g)
        return vx_fail(e, "%s: out of memory", where);
    in->named = g;
    inst_named *o = &g[in->named_count];
    if (!(o->name = strdup(name)))
        return vx_fail(e, "%s: out of memory", where);
    o->t0 = t0, o->t1 = s->mesh.triangle_count, o->animated = animated, o->instanced = instanced;
    in->named_count++;
    return 0;
}

int inst_parse_object(scene *s, const cJSON *o, const char *where, size_t v0, size_t t0, vx_err *e)
{
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(o, "instances"), *sc = cJSON_GetObjectItemCaseSensitive(o, "scatter");
    const cJSON *anim = cJSON_GetObjectItemCaseSensitive(o, "animation");
    const char *name = NULL;
    if (json_string(o, "name", where, &name, e))
        return -1;
    if (list && sc)
        return vx_fail(e, "%s.scatter: an object takes \"instances\" or \"scatter\", not both", where);
    if ((list || sc) && anim)
        return vx_fail(e, "%s.animation: an instanced object cannot be animated (animate a separate object instead)",
                       where);
    if (list || sc) {
        xform *x = NULL;
        int n = 0;
        if (list ? parse_list(list, where, &x, &n, e) : parse_scatter(s, sc, where, &x, &n, e)) {
            free(x);
            return -1;
        }
        scene_instancing *in = get(s, where, e);
        size_t nt = s->mesh.triangle_count - t0;
        if (!in || nt == 0 || (double)nt * n + (double)in->triangles > (double)INST_MAX_TRIANGLES) {
            free(x);
            if (!in)
                return -1;
            if (nt == 0)
                return vx_fail(e, "%s.%s: the object has no triangles to instance", where, list ? "instances" : "scatter");
            return vx_fail(e, "%s.%s: %d instances of %zu triangles make %.0f triangles with the scene's other "
                              "instances, more than the %zu a scene may hold",
                           where, list ? "instances" : "scatter", n, nt, (double)nt * n + (double)in->triangles,
                           (size_t)INST_MAX_TRIANGLES);
        }
        mesh *protos = realloc(in->protos, (size_t)(in->proto_count + 1) * sizeof *protos);
        inst_instance *inst = protos ? realloc(in->inst, (in->count + (size_t)n) * sizeof *inst) : NULL;
        if (protos)
            in->protos = protos;
        if (inst)
            in->inst = inst;
        if (!protos || !inst) {
            free(x);
            return vx_fail(e, "%s: out of memory for %d instances", where, n);
        }
        int p = in->proto_count++;
        if (extract(&s->mesh, v0, t0, &in->protos[p])) {
            free(x);
            return vx_fail(e, "%s: a triangle refers to a vertex of another object", where);
        }
        s->mesh.vertex_count = v0; /* the prototype itself is not drawn: its copies are */
        s->mesh.triangle_count = t0;
        for (int i = 0; i < n; i++) {
            inst_instance *I = &in->inst[in->count++];
            memset(I, 0, sizeof *I);
            double M[12];
            xform_matrix(&x[i], M);
            for (int k = 0; k < 12; k++)
                I->m[k] = (float)M[k];
            xform_prepare(&x[i], &I->x);
            I->proto = p;
            I->mirror = xform_mirrors(&x[i]);
            I->offset = in->triangles;
            in->triangles += nt;
        }
        free(x);
    }
    if (name && add_name(s, name, t0, anim != NULL, list || sc, where, e))
        return -1;
    return 0;
}

void inst_free(scene_instancing *in)
{
    if (!in)
        return;
    for (int i = 0; i < in->proto_count; i++)
        mesh_free(&in->protos[i]);
    for (int i = 0; i < in->named_count; i++)
        free(in->named[i].name);
    free(in->protos);
    free(in->inst);
    free(in->named);
    free(in);
}
