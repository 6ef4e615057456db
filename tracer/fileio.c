#include "fileio.h"

#include <errno.h>
#include <string.h>
#include <unistd.h>

FILE *fileio_open_temp(const char *path, char *tmp_path, size_t tmp_size, vx_err *e)
{
    snprintf(tmp_path, tmp_size, "%s.tmp.%ld", path, (long)getpid());
    FILE *f = fopen(tmp_path, "wb");
    if (!f)
        vx_fail(e, "%s: cannot write: %s", path, strerror(errno));
    return f;
}

int fileio_commit(FILE *f, const char *tmp_path, const char *path, vx_err *e)
{
    int bad = ferror(f);
    if (fclose(f) != 0 || bad) {
        remove(tmp_path);
        return vx_fail(e, "%s: write failed: %s", path, strerror(errno));
    }
    if (rename(tmp_path, path) != 0) {
        int err = errno;
        remove(tmp_path);
        return vx_fail(e, "%s: cannot rename the finished file into place: %s", path, strerror(err));
    }
    return 0;
}

void fileio_abort(FILE *f, const char *tmp_path)
{
    if (f)
        fclose(f);
    remove(tmp_path);
}

int fileio_write_text(const char *path, const char *text, vx_err *e)
{
    char tmp[4096 + 64];
    FILE *f = fileio_open_temp(path, tmp, sizeof tmp, e);
    if (!f)
        return -1;
    fputs(text, f);
    return fileio_commit(f, tmp, path, e);
}

int fileio_check_writable(const char *path, vx_err *e)
{
    char tmp[4096 + 64];
    FILE *f = fileio_open_temp(path, tmp, sizeof tmp, e);
    if (!f)
        return -1;
    fileio_abort(f, tmp);
    return 0;
}
