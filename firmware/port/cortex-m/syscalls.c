/*
 * syscalls.c - the few newlib hooks the images may pull in, all without a heap.
 *
 * Deliberately absent: _sbrk. newlib's malloc needs it, so an image that (even indirectly) uses
 * malloc - stdio buffers, printf("%f"), raise() - fails to link instead of carrying a heap.
 * abort() and __assert_func() are replaced here because newlib's versions reach malloc, through
 * raise() and fiprintf() respectively.
 */
#include <errno.h>
#include <stdlib.h>
#include <sys/stat.h>

#include "caekf_port.h"

int _write(int fd, const char *buf, int len);
int _read(int fd, char *buf, int len);
int _close(int fd);
int _lseek(int fd, int off, int whence);
int _fstat(int fd, struct stat *st);
int _isatty(int fd);
int _kill(int pid, int sig);
int _getpid(void);
void _exit(int status);
void __assert_func(const char *file, int line, const char *func, const char *expr);

int _write(int fd, const char *buf, int len)
{
    if (fd != 1 && fd != 2) {
        errno = EBADF;
        return -1;
    }
    caekf_console_write(buf, (size_t)len);
    return len;
}

int _read(int fd, char *buf, int len)
{
    (void)fd;
    (void)buf;
    (void)len;
    errno = ENOSYS;
    return -1;
}

int _close(int fd)
{
    (void)fd;
    return 0;
}

int _lseek(int fd, int off, int whence)
{
    (void)fd;
    (void)off;
    (void)whence;
    return 0;
}

int _fstat(int fd, struct stat *st)
{
    (void)fd;
    st->st_mode = S_IFCHR;
    return 0;
}

int _isatty(int fd)
{
    (void)fd;
    return 1;
}

int _kill(int pid, int sig)
{
    (void)pid;
    (void)sig;
    errno = EINVAL;
    return -1;
}

int _getpid(void) { return 1; }

void _exit(int status) { caekf_port_exit(status); }

void abort(void)
{
    caekf_console_puts("\n*** caekf port: abort()\n");
    caekf_port_exit(CAEKF_PORT_EXIT_ABORT);
}

void __assert_func(const char *file, int line, const char *func, const char *expr)
{
    caekf_console_puts("\n*** assertion failed: ");
    caekf_console_puts(expr != NULL ? expr : "?");
    caekf_console_puts(" (");
    caekf_console_puts(file != NULL ? file : "?");
    caekf_console_putc(':');
    caekf_console_put_i32(line);
    if (func != NULL) {
        caekf_console_puts(", ");
        caekf_console_puts(func);
    }
    caekf_console_puts(")\n");
    caekf_port_exit(CAEKF_PORT_EXIT_ABORT);
}
