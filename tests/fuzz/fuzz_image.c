/* libFuzzer harness: the image readers behind `voxlab compare` (OpenImageIO through
 * tracer/image/image_oiio.cpp, with our checks around it) and the metrics run on what they return. The
 * first byte picks the file name's extension (readers are chosen by it), the rest is the file. */
#include "fuzz_common.h"
#include "image.h"
#include "metrics.h"

int vx_oiio_read(const char *path, image *out, vx_err *e); /* tracer/image/image_oiio.cpp */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *const names[] = {"img.png", "img.exr", "img.hdr", "img.pfm", "img.tif", "img.jpg"};
    if (size < 1)
        return 0;
    const char *path = fuzz_write(names[data[0] % 6], data + 1, size - 1);
    image img;
    vx_err e;
    if (vx_oiio_read(path, &img, &e) != 0)
        return 0;
    /* Small images only through the metrics (SSIM is O(pixels) with a large constant). */
    if ((long long)img.width * img.height <= 256 * 256) {
        image_metrics m;
        metrics_compare(&img, &img, &m, &e);
        image heat;
        memset(&heat, 0, sizeof heat);
        if (metrics_heatmap(&img, &img, &heat, &e) == 0)
            image_free(&heat);
    }
    image_free(&img);
    return 0;
}
