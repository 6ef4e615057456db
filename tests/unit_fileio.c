/* tracer/core/fileio.c and tracer/core/readfile.c: a signal that ends the run removes the temporary file
 * being written (checked in a child that is killed by the signal, as a user's Ctrl-C would), and
 * input files are read only when they are regular files; an output's extension. */
#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "fileio.h"
#include "readfile.h"
#include "unit.h"

static char dir[] = "/tmp/voxlab_unit_fileio.XXXXXX";

static int entries(void)
{
    DIR *d = opendir(dir);
    int n = 0;
    for (struct dirent *de; d && (de = readdir(d));)
        n += de->d_name[0] != '.';
    if (d)
        closedir(d);
    return n;
}

/* A child creates a temporary file for dir/out.bin, checks that it exists, then gets sig. */
static void killed_while_writing(int sig, const char *name)
{
    char out[256], tmp[512], label[128];
    snprintf(out, sizeof out, "%s/out.bin", dir);
    pid_t pid = fork();
    if (pid == 0) {
        /* Under nohup (or a shell that ignores the signal) it arrives ignored, and the cleanup rightly
         * leaves an ignored signal alone: the test is about the default disposition. */
        signal(sig, SIG_DFL);
        fileio_install_signal_cleanup();
        vx_err e;
        FILE *f = fileio_open_temp(out, tmp, sizeof tmp, &e);
        if (!f || fputs("partial", f) < 0 || fflush(f) != 0 || access(tmp, F_OK) != 0)
            _exit(3);
        raise(sig);
        _exit(4); /* not reached: the handler ends the process by the same signal */
    }
    int status = 0;
    waitpid(pid, &status, 0);
    snprintf(label, sizeof label, "%s ends the process by the same signal", name);
    CHECK(label, WIFSIGNALED(status) && WTERMSIG(status) == sig);
    snprintf(label, sizeof label, "%s leaves no temporary file", name);
    CHECK(label, entries() == 0);
}

int main(void)
{
    if (!mkdtemp(dir)) {
        printf("not ok mkdtemp\n");
        return 1;
    }
    killed_while_writing(SIGTERM, "SIGTERM");
    killed_while_writing(SIGINT, "SIGINT");
    killed_while_writing(SIGHUP, "SIGHUP");
    killed_while_writing(SIGXFSZ, "SIGXFSZ");

    /* A committed file is no longer a temporary: the handler must not remove it. */
    char out[256], tmp[512];
    snprintf(out, sizeof out, "%s/kept.txt", dir);
    vx_err e;
    CHECK("write_text commits", fileio_write_text(out, "x\n", &e) == 0 && access(out, F_OK) == 0);
    pid_t pid = fork();
    if (pid == 0) {
        fileio_install_signal_cleanup();
        raise(SIGTERM);
        _exit(4);
    }
    waitpid(pid, NULL, 0);
    CHECK("a committed file survives a later signal", access(out, F_OK) == 0);
    unlink(out);

    /* A directory as the output is named as one. */
    CHECK("a directory is not a writable output",
          fileio_check_writable(dir, &e) != 0 && strstr(e.msg, "is a directory") && strstr(e.msg, dir));
    (void)tmp;

    /* Inputs: regular files only; /dev/zero, a FIFO and a directory are refused, not read. */
    size_t size;
    char *buf = readfile_all(dir, "scene file", 1 << 20, &size, &e);
    CHECK("readfile: a directory is refused", !buf && strstr(e.msg, "is a directory") && strstr(e.msg, dir));
    buf = readfile_all("/dev/zero", "PLY file", 1 << 20, &size, &e);
    CHECK("readfile: /dev/zero is refused (not read forever)",
          !buf && strstr(e.msg, "/dev/zero: cannot read PLY file: it is a character device"));
    char fifo[300];
    snprintf(fifo, sizeof fifo, "%s/fifo", dir);
    CHECK("mkfifo", mkfifo(fifo, 0600) == 0);
    buf = readfile_all(fifo, "PLY file", 1 << 20, &size, &e); /* would block forever if opened plainly */
    CHECK("readfile: a FIFO is refused without blocking", !buf && strstr(e.msg, "it is a FIFO"));
    unlink(fifo);
    snprintf(out, sizeof out, "%s/big.txt", dir);
    CHECK("write 100 bytes", fileio_write_text(out, "0123456789012345678901234567890123456789012345678901234567890123456789"
                                                    "012345678901234567890123456789\n", &e) == 0);
    buf = readfile_all(out, "scene file", 50, &size, &e);
    CHECK("readfile: a file over the limit is refused", !buf && strstr(e.msg, "more than the limit of 50"));
    buf = readfile_all(out, "scene file", 1000, &size, &e);
    CHECK("readfile: a regular file is read whole, NUL-terminated", buf && size == 101 && buf[100] == '\n' && buf[101] == 0);
    free(buf);
    unlink(out);
    /* Extensions: the last component's last '.', but a leading '.' names a hidden file. */
    CHECK("extension of a plain name", strcmp(fileio_extension("out/image.EXR"), ".EXR") == 0 &&
                                           strcmp(fileio_extension("a.b/c"), "") == 0 &&
                                           strcmp(fileio_extension("x.tar.gz"), ".gz") == 0);
    CHECK("a hidden file's leading dot is no extension",
          strcmp(fileio_extension(".exr"), "") == 0 && strcmp(fileio_extension("dir/.png"), "") == 0 &&
              strcmp(fileio_extension("..exr"), "") == 0 && strcmp(fileio_extension(".hidden.png"), ".png") == 0);
    snprintf(out, sizeof out, "%s/.exr", dir);
    CHECK("an output named only an extension is refused before anything is written",
          fileio_check_output("--out", out, ".exr", &e) != 0 && strstr(e.msg, "unsupported extension") &&
              access(out, F_OK) != 0);
    rmdir(dir);
    return unit_exit();
}
