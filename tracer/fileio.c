#include "fileio.h"

#include <errno.h>
#include <fcntl.h>
#include <stdatomic.h>
#include <string.h>
#include <unistd.h>

int fileio_temp_create(const char *path, char *tmp, size_t tmp_size, vx_err *e)
{
    /* pid + counter keeps concurrent writers (other processes, other threads) off each other's files. */
    static atomic_uint counter;
    unsigned n = atomic_fetch_add(&counter, 1u);
    int len = snprintf(tmp, tmp_size, "%s.tmp.%ld.%u", path, (long)getpid(), n);
    if (len < 0 || (size_t)len >= tmp_size)
        return vx_fail(e, "%s: cannot write: the path is too long", path);
    /* O_EXCL: never clobber a file we did not create; creating it here (rather than letting a format
     * library do it) gives us errno, hence a precise message for unwritable directories. */
    int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        int err = errno;
        const char *slash = strrchr(path, '/');
        const char *dir = ".";
        int dirlen = 1;
        if (slash) {
            dir = slash == path ? "/" : path;
            dirlen = slash == path ? 1 : (int)(slash - path);
        }
        return vx_fail(e, "%s: cannot write: cannot create a file in directory '%.*s': %s", path, dirlen, dir,
                       strerror(err));
    }
    close(fd);
    return 0;
}

int fileio_temp_commit(const char *tmp, const char *path, vx_err *e)
{
    if (rename(tmp, path) != 0) {
        int err = errno;
        unlink(tmp);
        return vx_fail(e, "%s: cannot write: rename from %s failed: %s", path, tmp, strerror(err));
    }
    return 0;
}

FILE *fileio_open_temp(const char *path, char *tmp_path, size_t tmp_size, vx_err *e)
{
    if (fileio_temp_create(path, tmp_path, tmp_size, e))
        return NULL;
    FILE *f = fopen(tmp_path, "wb");
    if (!f) {
        vx_fail(e, "%s: cannot write: %s", path, strerror(errno));
        unlink(tmp_path);
    }
    return f;
}

int fileio_commit(FILE *f, const char *tmp_path, const char *path, vx_err *e)
{
    int bad = ferror(f);
    if (fclose(f) != 0 || bad) {
        remove(tmp_path);
        return vx_fail(e, "%s: write failed: %s", path, strerror(errno));
    }
    return fileio_temp_commit(tmp_path, path, e);
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
    if (fileio_temp_create(path, tmp, sizeof tmp, e))
        return -1;
    unlink(tmp);
    return 0;
}
