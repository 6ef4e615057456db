#include "fileio.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdatomic.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* Temporary files in flight, so that a signal that ends the process (SIGINT, SIGTERM, SIGHUP,
 * SIGXFSZ) can remove them: a slot's name is written before its flag is set and the flag cleared
 * before the name is reused, so the handler only ever reads complete names. A handful of slots is
 * plenty: voxlab writes one file at a time (two with --stats). */
#define TEMP_SLOTS 8
static char temp_names[TEMP_SLOTS][4096 + 64];
static atomic_int temp_used[TEMP_SLOTS];

static void temp_register(const char *tmp)
{
    for (int i = 0; i < TEMP_SLOTS; i++) {
        int expected = 0;
        /* 2 = being filled (not yet for the handler), 1 = complete. */
        if (atomic_compare_exchange_strong(&temp_used[i], &expected, 2)) {
            snprintf(temp_names[i], sizeof temp_names[i], "%s", tmp);
            atomic_store(&temp_used[i], 1);
            return;
        }
    }
    /* All slots busy: the file is still removed on every error path, only not on a signal. */
}

static void temp_forget(const char *tmp)
{
    for (int i = 0; i < TEMP_SLOTS; i++)
        if (atomic_load(&temp_used[i]) == 1 && strcmp(temp_names[i], tmp) == 0) {
            atomic_store(&temp_used[i], 0);
            return;
        }
}

static void on_fatal_signal(int sig)
{
    int saved = errno;
    for (int i = 0; i < TEMP_SLOTS; i++)
        if (atomic_load(&temp_used[i]) == 1)
            unlink(temp_names[i]); /* async-signal-safe */
    /* Die of the same signal, so that the parent sees what happened (e.g. 130 for Ctrl-C). */
    signal(sig, SIG_DFL);
    raise(sig);
    errno = saved;
}

void fileio_install_signal_cleanup(void)
{
    static const int sigs[] = {SIGINT, SIGTERM, SIGHUP, SIGXFSZ};
    for (size_t i = 0; i < sizeof sigs / sizeof *sigs; i++) {
        struct sigaction old;
        /* A signal the caller ignores stays ignored (e.g. env --ignore-signal=XFSZ: then writes fail
         * with EFBIG and the error path removes the file). */
        if (sigaction(sigs[i], NULL, &old) == 0 && old.sa_handler == SIG_IGN)
            continue;
        struct sigaction sa;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_fatal_signal;
        sigemptyset(&sa.sa_mask);
        sigaction(sigs[i], &sa, NULL);
    }
}

int fileio_temp_create(const char *path, char *tmp, size_t tmp_size, vx_err *e)
{
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return vx_fail(e, "%s: cannot write: it is a directory (expected a file name)", path);
    /* pid + counter keeps concurrent writers (other processes, other threads) off each other's files. */
    static atomic_uint counter;
    unsigned n = atomic_fetch_add(&counter, 1u);
    int len = snprintf(tmp, tmp_size, "%s.tmp.%ld.%u", path, (long)getpid(), n);
    if (len < 0 || (size_t)len >= tmp_size)
        return vx_fail(e, "%s: cannot write: the path is too long", path);
    /* Registered before it exists: a signal between open and registration would otherwise leave it. */
    temp_register(tmp);
    /* O_EXCL: never clobber a file we did not create; creating it here (rather than letting a format
     * library do it) gives us errno, hence a precise message for unwritable directories. */
    int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        int err = errno;
        temp_forget(tmp);
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

void fileio_temp_discard(const char *tmp)
{
    unlink(tmp);
    temp_forget(tmp);
}

int fileio_temp_commit(const char *tmp, const char *path, vx_err *e)
{
    if (rename(tmp, path) != 0) {
        int err = errno;
        fileio_temp_discard(tmp);
        return vx_fail(e, "%s: cannot write: rename from %s failed: %s", path, tmp, strerror(err));
    }
    temp_forget(tmp);
    return 0;
}

FILE *fileio_open_temp(const char *path, char *tmp_path, size_t tmp_size, vx_err *e)
{
    if (fileio_temp_create(path, tmp_path, tmp_size, e))
        return NULL;
    FILE *f = fopen(tmp_path, "wb");
    if (!f) {
        vx_fail(e, "%s: cannot write: %s", path, strerror(errno));
        fileio_temp_discard(tmp_path);
    }
    return f;
}

int fileio_commit(FILE *f, const char *tmp_path, const char *path, vx_err *e)
{
    /* fflush first so that a full disk or the file-size limit is reported with its errno (ENOSPC,
     * EFBIG) rather than whatever fclose leaves behind. */
    int err = 0;
    if (fflush(f) != 0 || ferror(f))
        err = errno ? errno : EIO;
    if (fclose(f) != 0 && !err)
        err = errno ? errno : EIO;
    if (err) {
        fileio_temp_discard(tmp_path);
        return vx_fail(e, "%s: write failed: %s", path, strerror(err));
    }
    return fileio_temp_commit(tmp_path, path, e);
}

void fileio_abort(FILE *f, const char *tmp_path)
{
    if (f)
        fclose(f);
    fileio_temp_discard(tmp_path);
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
    fileio_temp_discard(tmp);
    return 0;
}

const char *fileio_extension(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *name = slash ? slash + 1 : path;
    /* A name's leading dots are not an extension: "-o .exr" would write a hidden file with no name. */
    while (*name == '.')
        name++;
    const char *dot = strrchr(name, '.');
    return dot ? dot : "";
}

int fileio_check_output(const char *option, const char *path, const char *ext, vx_err *e)
{
    if (fileio_check_writable(path, e)) /* first: a directory is named as one, not as an extension */
        return -1;
    if (strcasecmp(fileio_extension(path), ext) != 0)
        return vx_fail(e, "%s %s: unsupported extension '%s' (expected %s)", option, path, fileio_extension(path), ext);
    return 0;
}
