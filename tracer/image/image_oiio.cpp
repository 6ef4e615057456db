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
#include <cstdio>
#include <cstdlib>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

#include <OpenImageIO/filesystem.h>

#include "image.h"
#include "readfile.h"

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

// libpng's default error handler (OIIO's PNG reader installs no other) prints "libpng error: ..."
// to stderr before OIIO reports the same failure, which we print as one line of our own. While a
// reader runs, stderr goes to a memory file; afterwards everything but libpng's lines is passed on.
// VOXLAB_LIBRARY_STDERR=1 leaves stderr alone (for debugging a reader).
class libpng_lines_dropped {
public:
    libpng_lines_dropped()
    {
        const char *keep = std::getenv("VOXLAB_LIBRARY_STDERR");
        if (keep && *keep && *keep != '0')
            return;
        std::fflush(stderr);
        mem_ = memfd_create("voxlab-stderr", MFD_CLOEXEC);
        saved_ = mem_ >= 0 ? dup(2) : -1;
        if (saved_ < 0 || dup2(mem_, 2) < 0) {
            if (saved_ >= 0)
                close(saved_);
            if (mem_ >= 0)
                close(mem_);
            mem_ = saved_ = -1;
        }
    }
    ~libpng_lines_dropped()
    {
        if (mem_ < 0)
            return;
        std::fflush(stderr);
        dup2(saved_, 2);
        close(saved_);
        std::string text;
        char buf[4096];
        ssize_t n;
        for (off_t at = 0; (n = pread(mem_, buf, sizeof buf, at)) > 0; at += n)
            text.append(buf, size_t(n));
        close(mem_);
        size_t start = 0;
        while (start < text.size()) {
            size_t end = text.find('\n', start);
            end = end == std::string::npos ? text.size() : end + 1;
            if (text.compare(start, 14, "libpng error: ") != 0 && text.compare(start, 16, "libpng warning: ") != 0)
                (void)!write(2, text.data() + start, end - start);
            start = end;
        }
    }
    libpng_lines_dropped(const libpng_lines_dropped &) = delete;
    libpng_lines_dropped &operator=(const libpng_lines_dropped &) = delete;

private:
    int mem_ = -1, saved_ = -1;
};

extern "C" int vx_oiio_read(const char *path, image *out, vx_err *e)
{
    libpng_lines_dropped quiet;
    std::memset(out, 0, sizeof *out);
    // OIIO words a missing file as "no format reader"; check first for the real reason. Only
    // regular files: OIIO would block on a FIFO and read a device forever.
    if (readfile_check(path, "image", READFILE_MAX_BYTES, e))
        return -1;
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
    if ((long long)spec.width * spec.height > IMAGE_MAX_PIXELS)
        return vx_fail(e, "cannot read %s: %dx%d is %lld pixels, more than the limit of %lld", path, spec.width,
                       spec.height, (long long)spec.width * spec.height, IMAGE_MAX_PIXELS);
    // Anything past 4 channels (AOVs, depth...) has no place in an RGBA image; keep the first four.
    int channels = spec.nchannels < 4 ? spec.nchannels : 4;
    // Every reader (the metrics, the textures) takes a second or fourth channel for alpha, so it is
    // kept only where the file says it is one (OIIO names it: "A", a PNG's or TIFF's alpha). A
    // fourth that is not (R, G, B, Z) is left out; two channels that are not grey + alpha (an EXR's
    // R, G) have no reading as colour, and were compared as grey + alpha without a word.
    if (channels == 4 && spec.alpha_channel != 3)
        channels = 3;
    if (channels == 2 && spec.alpha_channel != 1) {
        std::string names;
        for (int c = 0; c < spec.nchannels && c < 8; c++)
            names += (c ? ", " : "") + (c < int(spec.channelnames.size()) ? spec.channelnames[size_t(c)] : "?");
        return vx_fail(e, "cannot read %s: its 2 channels (%s) are not grey + alpha (expected 1 grey channel, grey + "
                          "alpha, RGB or RGBA)",
                       path, one_line(names).c_str());
    }
    vx_err alloc_err;
    if (image_alloc(out, spec.width, spec.height, channels, &alloc_err) != 0)
        return vx_fail(e, "cannot read %s: %s", path, alloc_err.msg);
    if (!in->read_image(0, 0, 0, channels, TypeDesc::FLOAT, out->data)) {
        std::string msg = one_line(in->geterror());
        image_free(out);
        return vx_fail(e, "cannot read %s: %s", path, msg.c_str());
    }
    in->close();
    out->stored_8bit = spec.format == TypeDesc::UINT8;
    return 0;
}

// Writes all of buf to path, reporting the errno of any failure (ENOSPC, EFBIG, EIO...).
static int write_bytes(const std::vector<unsigned char> &buf, const char *path, const char *what, vx_err *e)
{
    int fd = open(path, O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0)
        return vx_fail(e, "cannot write %s: %s", what, std::strerror(errno));
    size_t done = 0;
    while (done < buf.size()) {
        ssize_t n = write(fd, buf.data() + done, buf.size() - done);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            int err = n < 0 ? errno : EIO;
            close(fd);
            return vx_fail(e, "cannot write %s: %s", what, std::strerror(err));
        }
        done += size_t(n);
    }
    if (close(fd) != 0)
        return vx_fail(e, "cannot write %s: %s", what, std::strerror(errno));
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
    // Encoded into memory and written by write_bytes: OIIO's PNG writer ignores the errors of its
    // own file writes (a full disk or the file-size limit gave exit 0 and an empty or truncated
    // file), so the bytes reach the disk through calls whose every error we see.
    std::vector<unsigned char> buf;
    Filesystem::IOVecOutput proxy(buf);
    if (!out->set_ioproxy(&proxy) || !out->open(path, spec))
        return vx_fail(e, "cannot write %s: %s", what, one_line(out->geterror()).c_str());
    bool ok = out->write_image(TypeDesc::UINT8, px);
    std::string msg = ok ? std::string() : one_line(out->geterror());
    if (!out->close() && ok) {
        ok = false;
        msg = one_line(out->geterror());
    }
    if (!ok)
        return vx_fail(e, "cannot write %s: %s", what, msg.c_str());
    return write_bytes(buf, path, what, e);
}
