/* EXR output through the OpenEXR C core API: one scanline part, 32-bit float channels (Y or R,G,B,
 * plus A), ZIP compression. Float rather than half because these files are ground truth for error
 * metrics: half would add ~1e-3 relative quantisation error to every comparison. */
#include <openexr.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

#include "fileio.h"
#include "image.h"

/* The library reports details through a callback; keep the first message for our error text
 * instead of letting it print to stderr behind the caller's back. */
typedef struct {
    char msg[512];
} exr_capture;

/* The capture of the write in progress on this thread. Not exr_get_user_data: the library calls the
 * handler while holding the context's lock, and exr_get_user_data takes that lock again, so a
 * failed write (a full disk, the file-size limit) deadlocked. */
static _Thread_local exr_capture *current_capture;

static void capture_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    exr_capture *cap = current_capture;
    if (cap && !cap->msg[0])
        snprintf(cap->msg, sizeof cap->msg, "%s (%s)", msg ? msg : "", exr_get_error_code_as_string(code));
}

/* A chunk that ZIP does not shrink must be stored raw: a reader takes a chunk whose stored size is
 * its raw size for raw pixels. OpenEXR 3.1's core library (Debian 12's) keeps the deflated bytes
 * when they come out exactly as long as the raw ones (it tests compressed > raw; upstream issue
 * 2306, fixed in 3.4), and those bytes were then read back as pixels: 16 rows of garbage, NaN
 * among them, in a 64x64 render (tests/unit_image.c makes such chunks). The library's compressor
 * runs, then this stores the raw bytes in that case, as the fixed library does. Thread-local, as
 * the capture is: the pipeline's function pointer has no user data. */
static _Thread_local exr_result_t (*library_compress)(exr_encode_pipeline_t *);

static exr_result_t compress_or_store_raw(exr_encode_pipeline_t *p)
{
    exr_result_t rv = library_compress(p);
    if (rv == EXR_ERR_SUCCESS && p->compressed_bytes == p->packed_bytes && p->compressed_buffer &&
        p->compressed_buffer != p->packed_buffer)
        memcpy(p->compressed_buffer, p->packed_buffer, p->packed_bytes);
    return rv;
}

static const char *channel_name(int channels, int c)
{
    static const char *grey[] = {"Y", "A"};
    static const char *rgba[] = {"R", "G", "B", "A"};
    return channels <= 2 ? grey[c] : rgba[c];
}

/* Writes img to tmp (already created, empty). Returns 0 or the failing exr_result_t. */
static exr_result_t write_file(const image *img, const char *tmp, exr_capture *cap)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = capture_error;
    current_capture = cap;
    exr_context_t f = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    int have_enc = 0;
    int part = 0, lines = 1;
    const int w = img->width, h = img->height, nc = img->channels;

    exr_result_t rv = exr_start_write(&f, tmp, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_add_part(f, NULL, EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(f, part, w, h, EXR_COMPRESSION_ZIP);
    for (int c = 0; c < nc && rv == EXR_ERR_SUCCESS; c++) {
        int alpha = (nc == 2 || nc == 4) && c == nc - 1;
        rv = exr_add_channel(f, part, channel_name(nc, c), EXR_PIXEL_FLOAT,
                             alpha ? EXR_PERCEPTUALLY_LINEAR : EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    }
    for (int k = 0; img->meta && k < img->meta->count && rv == EXR_ERR_SUCCESS; k++)
        rv = exr_attr_set_string(f, part, img->meta->entry[k].key, img->meta->entry[k].value);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_write_header(f);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_scanlines_per_chunk(f, part, &lines);

    for (int y = 0; y < h && rv == EXR_ERR_SUCCESS; y += lines) {
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(f, part, y, &cinfo);
        if (rv != EXR_ERR_SUCCESS)
            break;
        rv = have_enc ? exr_encoding_update(f, part, &cinfo, &enc) : exr_encoding_initialize(f, part, &cinfo, &enc);
        if (rv != EXR_ERR_SUCCESS)
            break;
        have_enc = 1;
        /* The library orders channels alphabetically (A,B,G,R), so match them by name to our
         * interleaved offsets; the strides let it read straight from img->data without a copy. */
        for (int k = 0; k < enc.channel_count; k++) {
            exr_coding_channel_info_t *ch = &enc.channels[k];
            int c = 0;
            while (c < nc && strcmp(ch->channel_name, channel_name(nc, c)) != 0)
                c++;
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = nc * (int32_t)sizeof(float);
            ch->user_line_stride = w * nc * (int32_t)sizeof(float);
            ch->encode_from_ptr = (const uint8_t *)(img->data + ((size_t)cinfo.start_y * w * nc + c));
        }
        if (y == 0) {
            rv = exr_encoding_choose_default_routines(f, part, &enc);
            if (rv == EXR_ERR_SUCCESS && enc.compress_fn) {
                library_compress = enc.compress_fn;
                enc.compress_fn = compress_or_store_raw;
            }
        }
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(f, part, &enc);
    }
    if (have_enc)
        exr_encoding_destroy(f, &enc);
    /* exr_finish flushes the chunk offset table, so its result matters as much as the writes'. */
    if (f) {
        exr_result_t frv = exr_finish(&f);
        if (rv == EXR_ERR_SUCCESS)
            rv = frv;
    }
    current_capture = NULL;
    return rv;
}

int image_write_exr(const image *img, const char *path, vx_err *e)
{
    if (!img || !img->data || img->width <= 0 || img->height <= 0 || img->channels < 1 || img->channels > 4)
        return vx_fail(e, "%s: cannot write an empty image or one with %d channels as EXR (expected 1-4)", path,
                       img ? img->channels : 0);
    char tmp[4096];
    if (fileio_temp_create(path, tmp, sizeof tmp, e) != 0)
        return -1;
    exr_capture cap = {{0}};
    exr_result_t rv = write_file(img, tmp, &cap);
    if (rv != EXR_ERR_SUCCESS) {
        fileio_temp_discard(tmp);
        return vx_fail(e, "cannot write %s: OpenEXR error: %s", path,
                       cap.msg[0] ? cap.msg : exr_get_default_error_message(rv));
    }
    return fileio_temp_commit(tmp, path, e);
}

int image_read_meta(const char *path, image_meta *out, vx_err *e)
{
    memset(out, 0, sizeof *out);
    if (strcasecmp(fileio_extension(path), ".exr") != 0)
        return 0;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = capture_error;
    exr_capture cap = {{0}};
    current_capture = &cap;
    exr_context_t f = NULL;
    exr_result_t rv = exr_start_read(&f, path, &init);
    int32_t count = 0;
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_attribute_count(f, 0, &count);
    for (int32_t i = 0; i < count && rv == EXR_ERR_SUCCESS && out->count < IMAGE_META_MAX; i++) {
        const exr_attribute_t *a = NULL;
        rv = exr_get_attribute_by_index(f, 0, EXR_ATTR_LIST_FILE_ORDER, i, &a);
        if (rv != EXR_ERR_SUCCESS || !a || a->type != EXR_ATTR_STRING || !a->name ||
            strncmp(a->name, IMAGE_META_PREFIX, strlen(IMAGE_META_PREFIX)) != 0 || !a->string)
            continue;
        image_meta_entry *x = &out->entry[out->count++];
        snprintf(x->key, sizeof x->key, "%s", a->name);
        snprintf(x->value, sizeof x->value, "%.*s", a->string->length, a->string->str ? a->string->str : "");
    }
    if (f)
        exr_finish(&f);
    current_capture = NULL;
    if (rv != EXR_ERR_SUCCESS)
        return vx_fail(e, "%s: cannot read its EXR header: %s", path,
                       cap.msg[0] ? cap.msg : exr_get_default_error_message(rv));
    return 0;
}
