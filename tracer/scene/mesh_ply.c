/* PLY reader (Greg Turk's polygon file format) for mesh_load_ply. The header is parsed into a list
 * of elements and their properties so that any property layout can be read: scanned meshes come
 * with confidence, intensity, per-vertex lists and extra elements in arbitrary order, and the only
 * safe way to skip what we do not use is to know every property's type. */
#include "mesh_load.h"
#include "readfile.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef enum { T_NONE, T_I8, T_U8, T_I16, T_U16, T_I32, T_U32, T_F32, T_F64 } ply_type;

typedef enum { FMT_ASCII, FMT_LE, FMT_BE } ply_format;

/* The properties the loader cares about; everything else is P_OTHER and skipped. */
typedef enum {
    P_OTHER, P_X, P_Y, P_Z, P_NX, P_NY, P_NZ, P_RED, P_GREEN, P_BLUE, P_U, P_V, P_INDICES
} ply_role;

typedef struct {
    ply_type type;       /* scalar type, or the item type of a list */
    ply_type count_type; /* T_NONE for scalars, the list's count type otherwise */
    ply_role role;
    char name[64];
} ply_property;

typedef struct {
    char name[64];
    size_t count;
    ply_property *props;
    size_t prop_count, prop_capacity;
} ply_element;

typedef struct {
    const char *path;
    ply_format format;
    ply_element *elems;
    size_t elem_count, elem_capacity;
    int body_line; /* the file's line number of the body's first line (the header's are tokenised away) */
} ply_header;

static void header_free(ply_header *h)
{
    for (size_t i = 0; i < h->elem_count; i++)
        free(h->elems[i].props);
    free(h->elems);
}

static const struct {
    const char *name;
    ply_type type;
} type_names[] = {
    {"char", T_I8},   {"int8", T_I8},     {"uchar", T_U8},   {"uint8", T_U8},     {"short", T_I16},
    {"int16", T_I16}, {"ushort", T_U16},  {"uint16", T_U16}, {"int", T_I32},      {"int32", T_I32},
    {"uint", T_U32},  {"uint32", T_U32},  {"float", T_F32},  {"float32", T_F32},  {"double", T_F64},
    {"float64", T_F64},
};

static ply_type parse_type(const char *s)
{
    for (size_t i = 0; i < sizeof type_names / sizeof type_names[0]; i++)
        if (strcmp(s, type_names[i].name) == 0)
            return type_names[i].type;
    return T_NONE;
}

static size_t type_size(ply_type t)
{
    switch (t) {
    case T_I8: case T_U8: return 1;
    case T_I16: case T_U16: return 2;
    case T_I32: case T_U32: case T_F32: return 4;
    case T_F64: return 8;
    default: return 0;
    }
}

static bool type_is_integer(ply_type t) { return t != T_F32 && t != T_F64 && t != T_NONE; }

/* Colour channels stored as integers span the type's full range (uchar 255 = full intensity). */
static double type_unit_scale(ply_type t)
{
    switch (t) {
    case T_I8: return 1.0 / 127.0;
    case T_U8: return 1.0 / 255.0;
    case T_I16: return 1.0 / 32767.0;
    case T_U16: return 1.0 / 65535.0;
    case T_I32: return 1.0 / 2147483647.0;
    case T_U32: return 1.0 / 4294967295.0;
    default: return 1.0;
    }
}

static ply_role scalar_role(const char *name)
{
    static const struct {
        const char *name;
        ply_role role;
    } roles[] = {
        {"x", P_X},         {"y", P_Y},           {"z", P_Z},           {"nx", P_NX},
        {"ny", P_NY},       {"nz", P_NZ},         {"red", P_RED},       {"green", P_GREEN},
        {"blue", P_BLUE},   {"diffuse_red", P_RED}, {"diffuse_green", P_GREEN},
        {"diffuse_blue", P_BLUE}, {"u", P_U},     {"v", P_V},           {"s", P_U},
        {"t", P_V},         {"texture_u", P_U},   {"texture_v", P_V},
    };
    for (size_t i = 0; i < sizeof roles / sizeof roles[0]; i++)
        if (strcmp(name, roles[i].name) == 0)
            return roles[i].role;
    return P_OTHER;
}

/* Whitespace within a line (a token's separator; '\r' of a CRLF line end too). */
static bool is_line_space(int c) { return c == ' ' || c == '\t' || c == '\r'; }

/* Splits the next header line (NUL-terminated in place) into at most `max` whitespace-separated
 * tokens; returns the token count and advances *cursor past the line. */
static int header_tokens(char **cursor, char *end, char **tok, int max)
{
    char *line = *cursor, *nl = memchr(line, '\n', (size_t)(end - line));
    char *stop = nl ? nl : end;
    *cursor = nl ? nl + 1 : end;
    *stop = '\0';
    int n = 0;
    for (char *s = line; n < max;) {
        while (is_line_space(*s))
            s++;
        if (!*s)
            break;
        tok[n++] = s;
        while (*s && !is_line_space(*s))
            s++;
        if (*s)
            *s++ = '\0';
    }
    return n;
}

/* Parses the header in buf (modified in place); *body receives the offset of the first data byte. */
static int parse_header(ply_header *h, char *buf, size_t size, size_t *body, vx_err *e)
{
    const char *path = h->path;
    if (size < 4 || memcmp(buf, "ply", 3) != 0 || (buf[3] != '\n' && buf[3] != '\r'))
        return vx_fail(e, "%s: not a PLY file (expected \"ply\" on the first line)", path);
    /* Find the end of the header before tokenising, so a file without one fails with a clear
     * message and token scanning can never run into binary data. */
    char *end_header = NULL;
    for (char *s = buf; (s = memmem(s, size - (size_t)(s - buf), "end_header", 10)) != NULL; s += 10)
        if (s[-1] == '\n') {
            end_header = s;
            break;
        }
    if (!end_header)
        return vx_fail(e, "%s: PLY header has no end_header line", path);
    char *body_start = memchr(end_header, '\n', size - (size_t)(end_header - buf));
    if (!body_start)
        return vx_fail(e, "%s: PLY header has no line break after end_header", path);
    *body = (size_t)(body_start + 1 - buf);
    h->body_line = 1;
    for (size_t i = 0; i < *body; i++)
        h->body_line += buf[i] == '\n';

    char *cursor = buf, *end = end_header;
    char *tok[8];
    bool have_format = false;
    int line_no = 0;
    header_tokens(&cursor, end, tok, 8); /* "ply" */
    line_no++;
    while (cursor < end) {
        int n = header_tokens(&cursor, end, tok, 8);
        line_no++;
        if (n == 0 || strcmp(tok[0], "comment") == 0 || strcmp(tok[0], "obj_info") == 0)
            continue;
        if (strcmp(tok[0], "format") == 0) {
            if (n < 3 || strcmp(tok[2], "1.0") != 0)
                return vx_fail(e, "%s: header line %d: unsupported format line (expected \"format "
                                  "ascii|binary_little_endian|binary_big_endian 1.0\")", path, line_no);
            if (strcmp(tok[1], "ascii") == 0)
                h->format = FMT_ASCII;
            else if (strcmp(tok[1], "binary_little_endian") == 0)
                h->format = FMT_LE;
            else if (strcmp(tok[1], "binary_big_endian") == 0)
                h->format = FMT_BE;
            else
                return vx_fail(e, "%s: header line %d: unknown PLY format \"%s\" (expected ascii, "
                                  "binary_little_endian or binary_big_endian)", path, line_no, tok[1]);
            have_format = true;
        } else if (strcmp(tok[0], "element") == 0) {
            char *num_end;
            errno = 0;
            unsigned long long count = n == 3 ? strtoull(tok[2], &num_end, 10) : 0;
            if (n != 3 || *num_end || tok[2][0] == '-' || errno || count > SIZE_MAX / 64)
                return vx_fail(e, "%s: header line %d: expected \"element NAME COUNT\" with a "
                                  "non-negative count", path, line_no);
            if (h->elem_count == h->elem_capacity) {
                h->elem_capacity = h->elem_capacity ? 2 * h->elem_capacity : 4;
                ply_element *grown = realloc(h->elems, h->elem_capacity * sizeof *grown);
                if (!grown)
                    return vx_fail(e, "%s: out of memory reading the PLY header", path);
                h->elems = grown;
            }
            ply_element *el = &h->elems[h->elem_count++];
            memset(el, 0, sizeof *el);
            snprintf(el->name, sizeof el->name, "%s", tok[1]);
            el->count = (size_t)count;
        } else if (strcmp(tok[0], "property") == 0) {
            if (h->elem_count == 0)
                return vx_fail(e, "%s: header line %d: property before any element", path, line_no);
            ply_element *el = &h->elems[h->elem_count - 1];
            ply_property p = {0};
            if (n == 5 && strcmp(tok[1], "list") == 0) {
                p.count_type = parse_type(tok[2]);
                p.type = parse_type(tok[3]);
                snprintf(p.name, sizeof p.name, "%s", tok[4]);
                if (!type_is_integer(p.count_type))
                    return vx_fail(e, "%s: header line %d: list count type \"%s\" is not an integer "
                                      "type (expected uchar, ushort, uint, ...)", path, line_no, tok[2]);
                if (p.type == T_NONE)
                    return vx_fail(e, "%s: header line %d: unknown property type \"%s\" (expected "
                                      "char, uchar, short, ushort, int, uint, float or double)",
                                   path, line_no, tok[3]);
                if (strcmp(p.name, "vertex_indices") == 0 || strcmp(p.name, "vertex_index") == 0)
                    p.role = P_INDICES;
            } else if (n == 3) {
                p.type = parse_type(tok[1]);
                snprintf(p.name, sizeof p.name, "%s", tok[2]);
                if (p.type == T_NONE)
                    return vx_fail(e, "%s: header line %d: unknown property type \"%s\" (expected "
                                      "char, uchar, short, ushort, int, uint, float or double)",
                                   path, line_no, tok[1]);
                p.role = scalar_role(p.name);
            } else
                return vx_fail(e, "%s: header line %d: expected \"property TYPE NAME\" or \"property "
                                  "list COUNT_TYPE ITEM_TYPE NAME\"", path, line_no);
            if (el->prop_count == el->prop_capacity) {
                el->prop_capacity = el->prop_capacity ? 2 * el->prop_capacity : 8;
                ply_property *grown = realloc(el->props, el->prop_capacity * sizeof *grown);
                if (!grown)
                    return vx_fail(e, "%s: out of memory reading the PLY header", path);
                el->props = grown;
            }
            el->props[el->prop_count++] = p;
        } else
            return vx_fail(e, "%s: header line %d: unknown keyword \"%s\" (expected format, element, "
                              "property, comment or end_header)", path, line_no, tok[0]);
    }
    if (!have_format)
        return vx_fail(e, "%s: PLY header has no format line (expected \"format ascii|"
                          "binary_little_endian|binary_big_endian 1.0\")", path);
    return 0;
}

/* ---- body reading -------------------------------------------------------------------------- */

typedef struct {
    const unsigned char *p, *end;
    ply_format format;
    bool swap; /* binary byte order differs from the host's */
} ply_reader;

static uint16_t bswap16(uint16_t v) { return (uint16_t)((v >> 8) | (v << 8)); }
static uint32_t bswap32(uint32_t v) { return __builtin_bswap32(v); }
static uint64_t bswap64(uint64_t v) { return __builtin_bswap64(v); }

/* The first byte at or after s that is not ASCII whitespace (end when none is). */
static const unsigned char *skip_ascii_space(const unsigned char *s, const unsigned char *end)
{
    while (s < end && (is_line_space(*s) || *s == '\n'))
        s++;
    return s;
}

/* How much of the ASCII token at s a message shows: up to its end, at most 32 bytes. */
static int shown_token_length(const unsigned char *s)
{
    size_t len = strcspn((const char *)s, " \t\r\n");
    return (int)(len < 32 ? len : 32);
}

/* Reads one value of type t as a double (exact for every PLY type, including uint and float).
 * Returns false at the end of the data or, for ASCII, on a token that is not a number. */
static bool read_value(ply_reader *r, ply_type t, double *out)
{
    if (r->format == FMT_ASCII) {
        const unsigned char *s = skip_ascii_space(r->p, r->end);
        if (s >= r->end)
            return false;
        /* The buffer is NUL-terminated one past r->end, so strtod cannot run off it. */
        char *num_end;
        double v = strtod((const char *)s, &num_end);
        if ((const unsigned char *)num_end == s)
            return false;
        r->p = (const unsigned char *)num_end;
        *out = v;
        return true;
    }
    size_t n = type_size(t);
    if ((size_t)(r->end - r->p) < n)
        return false;
    const unsigned char *s = r->p;
    r->p += n;
    /* memcpy rather than pointer casts: the data has no alignment guarantee. */
    switch (t) {
    case T_I8: *out = (int8_t)s[0]; return true;
    case T_U8: *out = s[0]; return true;
    case T_I16: case T_U16: {
        uint16_t v;
        memcpy(&v, s, 2);
        if (r->swap)
            v = bswap16(v);
        *out = t == T_I16 ? (double)(int16_t)v : (double)v;
        return true;
    }
    case T_I32: case T_U32: case T_F32: {
        uint32_t v;
        memcpy(&v, s, 4);
        if (r->swap)
            v = bswap32(v);
        if (t == T_F32) {
            float f;
            memcpy(&f, &v, 4);
            *out = f;
        } else
            *out = t == T_I32 ? (double)(int32_t)v : (double)v;
        return true;
    }
    case T_F64: {
        uint64_t v;
        memcpy(&v, s, 8);
        if (r->swap)
            v = bswap64(v);
        memcpy(out, &v, 8);
        return true;
    }
    default: return false;
    }
}

/* Skips one property (scalar or list) without interpreting it. */
static bool skip_property(ply_reader *r, const ply_property *p)
{
    double count = 1.0, dummy;
    if (p->count_type != T_NONE) {
        if (!read_value(r, p->count_type, &count) || count < 0)
            return false;
    }
    if (r->format != FMT_ASCII) {
        /* Binary lists skip in one step: long per-vertex lists stay cheap. */
        size_t bytes = (size_t)count * type_size(p->type);
        if ((size_t)(r->end - r->p) < bytes)
            return false;
        r->p += bytes;
        return true;
    }
    for (double i = 0; i < count; i++)
        if (!read_value(r, p->type, &dummy))
            return false;
    return true;
}

static const ply_element *find_element(const ply_header *h, const char *name)
{
    for (size_t i = 0; i < h->elem_count; i++)
        if (strcmp(h->elems[i].name, name) == 0)
            return &h->elems[i];
    return NULL;
}

static bool element_has(const ply_element *el, ply_role role)
{
    for (size_t i = 0; i < el->prop_count; i++)
        if (el->props[i].role == role)
            return true;
    return false;
}

/* The message for a failed read inside element `what` instance `index`: ASCII files can also fail on
 * a token that is not a number, which deserves a different message from running out of data. */
static int body_error(const ply_reader *r, const ply_header *h, const char *what, size_t index,
                      size_t count, vx_err *e)
{
    if (r->format == FMT_ASCII) {
        const unsigned char *s = skip_ascii_space(r->p, r->end);
        if (s < r->end)
            return vx_fail(e, "%s: %s %zu: expected a number, found \"%.*s\"", h->path, what, index,
                           shown_token_length(s), (const char *)s);
    }
    return vx_fail(e, "%s: truncated: the file ends inside %s %zu of %zu", h->path, what, index, count);
}

/* Reads the vertex element's instances and appends them to the mesh. */
static int read_vertices(ply_reader *r, const ply_header *h, const ply_element *el, bool has_normals,
                         bool has_colors, mesh *out, vx_err *e)
{
    for (size_t i = 0; i < el->count; i++) {
        double val[P_INDICES + 1] = {0};
        val[P_RED] = val[P_GREEN] = val[P_BLUE] = 1.0;
        for (size_t k = 0; k < el->prop_count; k++) {
            const ply_property *p = &el->props[k];
            if (p->role == P_OTHER || p->count_type != T_NONE) {
                if (!skip_property(r, p))
                    return body_error(r, h, "vertex", i, el->count, e);
                continue;
            }
            double v;
            if (!read_value(r, p->type, &v))
                return body_error(r, h, "vertex", i, el->count, e);
            if (p->role >= P_RED && p->role <= P_BLUE)
                v *= type_unit_scale(p->type);
            val[p->role] = v;
        }
        vec3 pos = v3((float)val[P_X], (float)val[P_Y], (float)val[P_Z]);
        /* Checked after the float conversion: a finite double beyond FLT_MAX is just as unusable. */
        if (!isfinite(pos.x) || !isfinite(pos.y) || !isfinite(pos.z))
            return vx_fail(e, "%s: vertex %zu has a non-finite coordinate (%g, %g, %g)", h->path, i,
                           val[P_X], val[P_Y], val[P_Z]);
        vec3 n = v3(0.0f, 0.0f, 1.0f);
        if (has_normals) {
            n = v3((float)val[P_NX], (float)val[P_NY], (float)val[P_NZ]);
            if (!isfinite(n.x) || !isfinite(n.y) || !isfinite(n.z))
                return vx_fail(e, "%s: vertex %zu has a non-finite normal", h->path, i);
            /* Scanners write unnormalised normals. A zero one stays zero: the shading then takes
             * the face's geometric normal (rt_shade), as for an OBJ `vn 0 0 0`. */
            n = v3_normalize_or(n, v3(0.0f, 0.0f, 0.0f));
        }
        float u = (float)val[P_U], v = (float)val[P_V];
        if (!isfinite(u) || !isfinite(v)) /* a NaN texel lookup would make NaN pixels */
            return vx_fail(e, "%s: vertex %zu has a non-finite texture coordinate (%g, %g)", h->path, i, val[P_U],
                           val[P_V]);
        uint32_t vi = mesh_add_vertex(out, pos, n, u, v);
        if (has_colors) {
            /* An albedo factor (scene.c's parse_albedo says why): float channels may hold anything. */
            for (int k = P_RED; k <= P_BLUE; k++)
                if (!(val[k] >= 0.0 && val[k] <= 1.0))
                    return vx_fail(e, "%s: vertex %zu has a colour channel of %g: expected 0 to 1 (an albedo)", h->path,
                                   i, val[k]);
            mesh_set_vertex_color(out, vi, v3((float)val[P_RED], (float)val[P_GREEN], (float)val[P_BLUE]));
        }
    }
    return 0;
}

/* Reads the face element, fan-triangulating each polygon. Indices are checked against the file's
 * vertex count (known from the header, so the face element may even precede the vertex element)
 * and offset by `base`, the mesh's vertex count before this file. */
static int read_faces(ply_reader *r, const ply_header *h, const ply_element *el, uint32_t base,
                      size_t vertex_count, uint32_t material, mesh *out, vx_err *e)
{
    for (size_t f = 0; f < el->count; f++) {
        for (size_t k = 0; k < el->prop_count; k++) {
            const ply_property *p = &el->props[k];
            if (p->role != P_INDICES) {
                if (!skip_property(r, p))
                    return body_error(r, h, "face", f, el->count, e);
                continue;
            }
            double count;
            if (!read_value(r, p->count_type, &count))
                return body_error(r, h, "face", f, el->count, e);
            if (count < 0 || count != floor(count) || count > UINT32_MAX)
                return vx_fail(e, "%s: face %zu has an invalid vertex count %g (expected a "
                                  "non-negative integer)", h->path, f, count);
            uint32_t first = 0, prev = 0;
            for (uint32_t j = 0; j < (uint32_t)count; j++) {
                double idx;
                if (!read_value(r, p->type, &idx))
                    return body_error(r, h, "face", f, el->count, e);
                if (!(idx >= 0 && idx < (double)vertex_count && idx == floor(idx)))
                    return vx_fail(e, "%s: face %zu has vertex index %.17g out of range (expected "
                                      "0 to %zu)", h->path, f, idx, vertex_count ? vertex_count - 1 : 0);
                uint32_t cur = base + (uint32_t)idx;
                /* Fan triangulation is exact for the convex polygons scanners and exporters write;
                 * faces with fewer than three corners add nothing. */
                if (j == 0)
                    first = cur;
                else if (j >= 2)
                    mesh_add_triangle(out, first, prev, cur, material);
                prev = cur;
            }
        }
    }
    return 0;
}

static int read_body(ply_reader *r, const ply_header *h, const ply_element *verts,
                     const ply_element *faces, bool has_normals, bool has_colors, uint32_t base,
                     uint32_t material, mesh *out, vx_err *e)
{
    for (size_t i = 0; i < h->elem_count; i++) {
        const ply_element *el = &h->elems[i];
        int rc = 0;
        if (el == verts)
            rc = read_vertices(r, h, el, has_normals, has_colors, out, e);
        else if (el == faces)
            rc = read_faces(r, h, el, base, verts->count, material, out, e);
        else
            /* Unused elements (edges, materials, range grids) are skipped property by property,
             * since their lists make their size unknowable otherwise. */
            for (size_t n = 0; n < el->count && rc == 0; n++)
                for (size_t k = 0; k < el->prop_count && rc == 0; k++)
                    if (!skip_property(r, &el->props[k]))
                        rc = body_error(r, h, el->name, n, el->count, e);
        if (rc)
            return rc;
    }
    /* ASCII values are read as a stream of numbers, so a line with more values than its element's
     * properties shifts every value after it; at the end that shows as values left over (the audit:
     * a last face "3 0 1 2 7" was taken without a word). Binary data past the elements is left alone. */
    if (r->format == FMT_ASCII) {
        const unsigned char *q = skip_ascii_space(r->p, r->end);
        if (q < r->end)
            return vx_fail(e, "%s: values left after the last element (\"%.*s\"...): the header's element counts or a "
                              "line's values do not match its properties",
                           h->path, shown_token_length(q), (const char *)q);
    }
    return 0;
}

/* Values on [p, line_end) from the first, counted; *need: how many the element's properties take,
 * reading a list's count where the line has it (SIZE_MAX when a count is missing or no count). */
static size_t ascii_line_values(const ply_element *el, const char *p, const char *line_end, size_t *need)
{
    size_t have = 0, next_prop_at = 0, prop = 0;
    *need = 0;
    for (const char *s = p;;) {
        while (s < line_end && is_line_space(*s))
            s++;
        if (s >= line_end)
            break;
        const char *tok = s;
        while (s < line_end && !is_line_space(*s))
            s++;
        if (have == next_prop_at && prop < el->prop_count) {
            /* The first value of property `prop`: a scalar takes one, a list 1 + its count. */
            size_t take = 1;
            if (el->props[prop].count_type != T_NONE) {
                char *num_end;
                double count = strtod(tok, &num_end);
                if (num_end == tok || !(count >= 0 && count < 1e9) || count != floor(count)) {
                    *need = SIZE_MAX;
                    return have + 1;
                }
                take += (size_t)count;
            }
            next_prop_at += take;
            prop++;
        }
        have++;
    }
    *need = prop < el->prop_count ? SIZE_MAX : next_prop_at;
    return have;
}

/* After a failed ASCII body: the first line whose values do not fit its element's properties, if
 * there is one, replaces the reader's message (into *e, returning 1; else 0). Why: values are read as
 * a stream, so a line with a value too many or too few shifts everything after it, and the read
 * failed later, on another element, or on the file's end ("truncated"), far from the line at fault.
 * An ASCII PLY holds one element a line. */
static int ascii_bad_line(const ply_header *h, const char *buf, size_t body, size_t size, vx_err *e)
{
    int line = h->body_line;
    const char *p = buf + body, *end = buf + size;
    for (size_t k = 0; k < h->elem_count; k++) {
        const ply_element *el = &h->elems[k];
        if (el->prop_count == 0)
            continue; /* its elements hold no values, and no line */
        for (size_t n = 0; n < el->count; n++, line++) {
            const char *line_end;
            for (;; line++) { /* blank lines carry no element */
                line_end = p < end ? memchr(p, '\n', (size_t)(end - p)) : NULL;
                line_end = line_end ? line_end : end;
                const char *s = p;
                while (s < line_end && is_line_space(*s))
                    s++;
                if (s < line_end)
                    break;
                if (line_end >= end)
                    return 0; /* the file ends first: the reader's "truncated" says so */
                p = line_end + 1;
            }
            size_t need, have = ascii_line_values(el, p, line_end, &need);
            if (have != need) {
                if (need == SIZE_MAX)
                    return vx_fail(e, "%s: line %d (%s %zu): %zu values, too few for its element's %zu properties "
                                      "(an ASCII PLY holds one element a line)",
                                   h->path, line, el->name, n, have, el->prop_count);
                return vx_fail(e, "%s: line %d (%s %zu): %zu values where its properties take %zu (an ASCII PLY "
                                  "holds one element a line)",
                               h->path, line, el->name, n, have, need);
            }
            p = line_end < end ? line_end + 1 : end;
        }
    }
    return 0;
}

/* Reads the whole file at once (the bunny is 1.3 MB; parsing from memory is what keeps loads far
 * below a frame), NUL-terminated so ASCII numbers can be parsed with strtod. */
static char *read_file(const char *path, size_t *size, vx_err *e)
{
    return readfile_all(path, "PLY file", READFILE_MAX_BYTES, size, e);
}

int mesh_load_ply(const char *path, mesh *out, uint32_t material, vx_err *e)
{
    size_t size = 0, body = 0;
    char *buf = read_file(path, &size, e);
    if (!buf)
        return -1;
    ply_header h = {.path = path};
    size_t v0 = out->vertex_count, t0 = out->triangle_count;
    int rc = parse_header(&h, buf, size, &body, e);
    const ply_element *verts = NULL, *faces = NULL;
    if (rc == 0) {
        verts = find_element(&h, "vertex");
        faces = find_element(&h, "face");
        if (!verts)
            rc = vx_fail(e, "%s: no \"element vertex\" in the PLY header (expected a vertex element "
                            "with x, y, z)", path);
        else if (!element_has(verts, P_X) || !element_has(verts, P_Y) || !element_has(verts, P_Z))
            rc = vx_fail(e, "%s: the vertex element lacks property %s (expected scalar x, y and z)",
                         path, !element_has(verts, P_X) ? "x" : !element_has(verts, P_Y) ? "y" : "z");
        else if (!faces)
            rc = vx_fail(e, "%s: no \"element face\" in the PLY header (expected a face element "
                            "with a vertex_indices list)", path);
        else if (!element_has(faces, P_INDICES))
            rc = vx_fail(e, "%s: the face element has no vertex_indices list (expected \"property "
                            "list uchar int vertex_indices\")", path);
        else if (verts->count > (size_t)UINT32_MAX - v0)
            rc = vx_fail(e, "%s: %zu vertices do not fit 32-bit indices", path, verts->count);
    }
    if (rc == 0)
        for (size_t k = 0; k < faces->prop_count && rc == 0; k++)
            if (faces->props[k].role == P_INDICES && !type_is_integer(faces->props[k].type))
                rc = vx_fail(e, "%s: face vertex_indices list holds %s values (expected an integer "
                                "type such as int or uint)", path,
                             faces->props[k].type == T_F32 ? "float" : "double");
    if (rc == 0) {
        bool has_normals = element_has(verts, P_NX) && element_has(verts, P_NY) && element_has(verts, P_NZ);
        bool has_colors = element_has(verts, P_RED) && element_has(verts, P_GREEN) &&
                          element_has(verts, P_BLUE);
        bool host_big = __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__;
        ply_reader r = {
            .p = (const unsigned char *)buf + body,
            .end = (const unsigned char *)buf + size,
            .format = h.format,
            .swap = h.format != FMT_ASCII && (h.format == FMT_BE) != host_big,
        };
        rc = read_body(&r, &h, verts, faces, has_normals, has_colors, (uint32_t)v0, material, out, e);
        vx_err at_line;
        if (rc != 0 && h.format == FMT_ASCII && ascii_bad_line(&h, buf, body, size, &at_line))
            *e = at_line;
        if (rc == 0 && !has_normals)
            mesh_smooth_normals(out, v0, t0);
    }
    if (rc != 0) {
        /* Leave the mesh as the caller gave it: a failed load must not leave half a model behind. */
        out->vertex_count = v0;
        out->triangle_count = t0;
    }
    header_free(&h);
    free(buf);
    return rc;
}
