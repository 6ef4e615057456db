#include "readfile.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *kind_of(mode_t m)
{
    if (S_ISDIR(m))
        return "a directory";
    if (S_ISFIFO(m))
        return "a FIFO";
    if (S_ISCHR(m))
        return "a character device";
    if (S_ISBLK(m))
        return "a block device";
    if (S_ISSOCK(m))
        return "a socket";
    return "not a regular file";
}

static int check_stat(const char *path, const char *what, unsigned long long max_bytes, const struct stat *st,
                      vx_err *e)
{
    if (!S_ISREG(st->st_mode))
        return vx_fail(e, "%s: cannot read %s: it is %s, not a regular file", path, what, kind_of(st->st_mode));
    if ((unsigned long long)st->st_size > max_bytes)
        return vx_fail(e, "%s: cannot read %s: %lld bytes is more than the limit of %llu", path, what,
                       (long long)st->st_size, max_bytes);
    return 0;
}

int readfile_open(const char *path, const char *what, unsigned long long max_bytes, off_t *size, vx_err *e)
{
    /* O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer before fstat can
     * tell us what it is. It does not affect reads of regular files. */
    int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
    if (fd < 0) {
        vx_fail(e, "%s: cannot open %s: %s", path, what, strerror(errno));
        return -1;
    }
    struct stat st;
    if (fstat(fd, &st) != 0) {
        vx_fail(e, "%s: cannot open %s: %s", path, what, strerror(errno));
        close(fd);
        return -1;
    }
    if (check_stat(path, what, max_bytes, &st, e)) {
        close(fd);
        return -1;
    }
    *size = st.st_size;
    return fd;
}

int readfile_check(const char *path, const char *what, unsigned long long max_bytes, vx_err *e)
{
    off_t size;
    int fd = readfile_open(path, what, max_bytes, &size, e);
    if (fd < 0)
        return -1;
    close(fd);
    return 0;
}

char *readfile_all(const char *path, const char *what, unsigned long long max_bytes, size_t *size, vx_err *e)
{
    off_t st_size;
    int fd = readfile_open(path, what, max_bytes, &st_size, e);
    if (fd < 0)
        return NULL;
    /* Read up to one byte past the size fstat gave, to notice a file that grew meanwhile. */
    size_t cap = (size_t)st_size + 1;
    char *buf = malloc(cap + 1);
    if (!buf) {
        close(fd);
        vx_fail(e, "%s: cannot read %s: out of memory for %lld bytes", path, what, (long long)st_size);
        return NULL;
    }
    size_t got = 0;
    while (got < cap) {
        ssize_t r = read(fd, buf + got, cap - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0) {
            vx_fail(e, "%s: cannot read %s: %s", path, what, strerror(errno));
            free(buf);
            close(fd);
            return NULL;
        }
        if (r == 0)
            break;
        got += (size_t)r;
    }
    close(fd);
    if (got != (size_t)st_size) {
        vx_fail(e, "%s: cannot read %s: it changed size while being read", path, what);
        free(buf);
        return NULL;
    }
    buf[got] = 0;
    *size = got;
    return buf;
}
