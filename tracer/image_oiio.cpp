// Thin C++ shim over OpenImageIO: reading any format as float, and storing 8-bit PNG samples that
// image.c has already sRGB-encoded. Everything colour-related stays in our C code so that the
// numbers are ours and testable; OIIO only does container I/O.
//
// Built as a plugin, build/libvoxlab_oiio.so, that image_oiio_plugin.c opens on first use:
// linking OpenImageIO (and its ~250 shared libraries) into voxlab costs ~1 s at every start, which
// every truth/bake/render run would pay for nothing. The plugin calls back into the executable
// (vx_fail, image_alloc, image_free), which exports them (-rdynamic).
#include <OpenImageIO/imageio.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <sys/stat.h>

#include "image.h"

using namespace OIIO;

// OIIO's error strings can span lines; our errors are one line each.
static std::string one_line(std::string s)
{
    for (char &ch : s)
        if (ch == '\n' || ch == '\r')
            ch = ' ';
    while (!s.empty() && s.back() == ' ')
        s.pop_back();
    return s.empty() ? std::string("unknown error") : s;
}

extern "C" int vx_oiio_read(const char *path, image *out, vx_err *e)
{
    std::memset(out, 0, sizeof *out);
    // OIIO words a missing file as "no format reader"; check first for the real reason.
    struct stat st;
    if (stat(path, &st) != 0)
        return vx_fail(e, "cannot read %s: %s", path, std::strerror(errno));
    if (S_ISDIR(st.st_mode))
        return vx_fail(e, "cannot read %s: it is a directory", path);
    // Ask readers to leave unassociated alpha alone: by default OIIO premultiplies PNG/TIFF colour
    // by alpha on read, which would not be "values as stored".
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = ImageInput::open(path, &config);
    if (!in)
        return vx_fail(e, "cannot read %s: %s", path, one_line(OIIO::geterror()).c_str());
    const ImageSpec &spec = in->spec();
    if (spec.deep)
        return vx_fail(e, "cannot read %s: deep images are not supported", path);
    if (spec.depth > 1)
        return vx_fail(e, "cannot read %s: volume images (depth %d) are not supported", path, spec.depth);
    // Anything past 4 channels (AOVs, depth...) has no place in an RGBA image; keep the first four.
    int channels = spec.nchannels < 4 ? spec.nchannels : 4;
    vx_err alloc_err;
    if (image_alloc(out, spec.width, spec.height, channels, &alloc_err) != 0)
        return vx_fail(e, "cannot read %s: %s", path, alloc_err.msg);
    if (!in->read_image(0, 0, 0, channels, TypeDesc::FLOAT, out->data)) {
        std::string msg = one_line(in->geterror());
        image_free(out);
        return vx_fail(e, "cannot read %s: %s", path, msg.c_str());
    }
    in->close();
    return 0;
}

extern "C" int vx_oiio_write_png8(const unsigned char *px, int width, int height, int channels,
                                     const char *path, const char *what, vx_err *e)
{
    // Created by format name because `path` is a temporary name whose extension is not ".png".
    auto out = ImageOutput::create("png");
    if (!out)
        return vx_fail(e, "cannot write %s: OpenImageIO has no PNG writer: %s", what,
                       one_line(OIIO::geterror()).c_str());
    ImageSpec spec(width, height, channels, TypeDesc::UINT8);
    if (channels == 2 || channels == 4)
        spec.alpha_channel = channels - 1;
    // Our samples are final: alpha is unassociated (PNG's convention), so OIIO must not divide the
    // colour by it; the colour space tag only labels what image.c already encoded.
    spec.attribute("oiio:UnassociatedAlpha", 1);
    spec.attribute("oiio:ColorSpace", "sRGB");
    if (!out->open(path, spec))
        return vx_fail(e, "cannot write %s: %s", what, one_line(out->geterror()).c_str());
    bool ok = out->write_image(TypeDesc::UINT8, px);
    std::string msg = ok ? std::string() : one_line(out->geterror());
    if (!out->close() && ok) {
        ok = false;
        msg = one_line(out->geterror());
    }
    if (!ok)
        return vx_fail(e, "cannot write %s: %s", what, msg.c_str());
    return 0;
}
