#define _POSIX_C_SOURCE 200809L /* mkstemp, fdopen */
#include "tool.h"

#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* The temporary file of the output being written, removed if the run is interrupted (SIGINT, SIGTERM,
 * SIGHUP) so that even then nothing is left behind. One output per process. */
static char pending_tmp[4096];
static volatile sig_atomic_t pending;

static void on_signal(int sig)
{
    if (pending) {
        (void)unlink(pending_tmp);
    }
    signal(sig, SIG_DFL);
    raise(sig);
}

static void watch_signals(const char *tmp)
{
    static const int sigs[] = {SIGINT, SIGTERM, SIGHUP};
    struct sigaction sa;
    unsigned i;
    memcpy(pending_tmp, tmp, sizeof pending_tmp);
    pending = 1;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    for (i = 0; i < sizeof sigs / sizeof sigs[0]; ++i) {
        (void)sigaction(sigs[i], &sa, NULL);
    }
}

void caekf_tool_version(const char *tool, const char *scalar) { printf("%s %s (%s)\n", tool, CAEKF_VERSION, scalar); }

int caekf_tool_check_input(const char *path, int allow_stdin, char *err, unsigned err_len)
{
    struct stat st;
    FILE *f;
    if (allow_stdin && strcmp(path, "-") == 0) {
        return 0;
    }
    if (stat(path, &st) != 0) {
        snprintf(err, err_len, "%s: cannot open: %s", path, strerror(errno));
        return CAEKF_EXIT_IO;
    }
    if (S_ISDIR(st.st_mode)) {
        snprintf(err, err_len, "%s: is a directory, expected a file", path);
        return CAEKF_EXIT_IO;
    }
    if ((f = fopen(path, "r")) == NULL) {
        snprintf(err, err_len, "%s: cannot open: %s", path, strerror(errno));
        return CAEKF_EXIT_IO;
    }
    fclose(f);
    return 0;
}

int caekf_output_open(caekf_output_t *o, const char *dest, char *err, unsigned err_len)
{
    struct stat st;
    const char *slash;
    int fd, n;
    memset(o, 0, sizeof *o);
    if (strcmp(dest, "-") == 0) {
        o->f = stdout;
        return 0;
    }
    if (stat(dest, &st) == 0 && S_ISDIR(st.st_mode)) {
        snprintf(err, err_len, "%s: is a directory, expected an output file name", dest);
        return CAEKF_EXIT_IO;
    }
    if (stat(dest, &st) == 0 && !S_ISREG(st.st_mode)) {
        if ((o->f = fopen(dest, "w")) == NULL) {
            snprintf(err, err_len, "%s: cannot write: %s", dest, strerror(errno));
            return CAEKF_EXIT_IO;
        }
        o->direct = 1;
        return 0;
    }
    slash = strrchr(dest, '/');
    if (slash == NULL) {
        n = snprintf(o->tmp, sizeof o->tmp, ".%s.tmp-XXXXXX", dest);
    } else {
        n = snprintf(o->tmp, sizeof o->tmp, "%.*s/.%s.tmp-XXXXXX", (int)(slash - dest), dest, slash + 1);
    }
    if (n < 0 || (size_t)n >= sizeof o->tmp) {
        snprintf(err, err_len, "%.200s: output path too long", dest);
        return CAEKF_EXIT_IO;
    }
    if ((fd = mkstemp(o->tmp)) < 0) {
        snprintf(err, err_len, "%s: cannot write: %s", dest, strerror(errno));
        o->tmp[0] = '\0';
        return CAEKF_EXIT_IO;
    }
    {
        mode_t mask = umask(0); /* mkstemp's 0600 is not what an output file should have: 0666 & ~umask */
        (void)umask(mask);
        (void)fchmod(fd, 0666 & ~mask);
    }
    if ((o->f = fdopen(fd, "w")) == NULL) {
        snprintf(err, err_len, "%s: cannot write: %s", dest, strerror(errno));
        close(fd);
        (void)unlink(o->tmp);
        o->tmp[0] = '\0';
        return CAEKF_EXIT_IO;
    }
    o->dest = dest;
    watch_signals(o->tmp);
    return 0;
}

int caekf_output_commit(caekf_output_t *o, char *err, unsigned err_len)
{
    int bad;
    if (o->dest == NULL) {
        int bad_out = o->f != NULL && (fflush(o->f) != 0 || ferror(o->f));
        if (o->direct) {
            bad_out |= fclose(o->f) != 0;
            o->f = NULL;
        }
        if (bad_out) {
            snprintf(err, err_len, "<output>: write failed: %s", strerror(errno));
            return CAEKF_EXIT_IO;
        }
        return 0;
    }
    bad = ferror(o->f) != 0;
    bad |= fclose(o->f) != 0;
    o->f = NULL;
    if (bad) {
        snprintf(err, err_len, "%s: write failed: %s", o->dest, strerror(errno));
        caekf_output_abort(o);
        return CAEKF_EXIT_IO;
    }
    pending = 0;
    if (rename(o->tmp, o->dest) != 0) {
        snprintf(err, err_len, "%s: cannot write: %s", o->dest, strerror(errno));
        caekf_output_abort(o);
        return CAEKF_EXIT_IO;
    }
    o->tmp[0] = '\0';
    return 0;
}

void caekf_output_abort(caekf_output_t *o)
{
    if (o->f != NULL && o->f != stdout) {
        fclose(o->f);
    }
    o->f = NULL;
    pending = 0;
    if (o->tmp[0] != '\0') {
        (void)unlink(o->tmp);
        o->tmp[0] = '\0';
    }
}
