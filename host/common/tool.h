/* What every host tool shares: the exit-code table, the version, and output written to a temporary file
 * in the destination's folder that is renamed into place only when the run succeeded (a failed run
 * leaves nothing behind). */
#ifndef CAEKF_HOST_TOOL_H
#define CAEKF_HOST_TOOL_H

#include <stdio.h>

/* One exit-code table for all tools (docs: README "Host tools"). */
enum {
    CAEKF_EXIT_OK = 0,
    CAEKF_EXIT_USAGE = 2,  /* bad command line */
    CAEKF_EXIT_INPUT = 3,  /* bad input: scenario, settings, measurement file */
    CAEKF_EXIT_IO = 4,     /* a file cannot be read or written (missing, a directory, disk full) */
    CAEKF_EXIT_NUMERIC = 5 /* the computation failed (estimator refused to start, non-finite result) */
};

/* The CMake project version, passed as a compile definition (one place: project(caekf VERSION ...)). */
#ifndef CAEKF_VERSION
#error "CAEKF_VERSION must be defined by the build (CMake project version)"
#endif

#define CAEKF_EXIT_TABLE "exit status: 0 ok, 2 usage, 3 bad input, 4 I/O error, 5 numerical failure\n"

/* Prints "<tool> <version> (<scalar>)" to stdout. */
void caekf_tool_version(const char *tool, const char *scalar);

/* Checks that path names a readable regular file (or is "-" when allow_stdin). Returns 0, or
 * CAEKF_EXIT_IO with a one-line message in err ("PATH: is a directory", "PATH: cannot open: ..."). */
int caekf_tool_check_input(const char *path, int allow_stdin, char *err, unsigned err_len);

typedef struct {
    FILE *f;
    const char *dest; /* final path, or NULL for stdout and special files */
    char tmp[4096];   /* temporary file beside dest */
    int direct;       /* f is dest itself (a device or a pipe such as /dev/null): closed, never renamed */
} caekf_output_t;

/* Opens the output: "-" is stdout; an existing file that is not a regular file (/dev/null, a FIFO) is
 * written in place, since renaming over it would replace the device; anything else is a temporary
 * file in dest's folder, so nothing exists at dest until caekf_output_commit. Returns 0, or
 * CAEKF_EXIT_IO with a message in err. */
int caekf_output_open(caekf_output_t *o, const char *dest, char *err, unsigned err_len);

/* Flushes, closes and renames the temporary file onto dest. Returns 0, or CAEKF_EXIT_IO with a message
 * (the temporary file is removed). */
int caekf_output_commit(caekf_output_t *o, char *err, unsigned err_len);

/* Closes and removes the temporary file (a failed run). Safe to call twice. */
void caekf_output_abort(caekf_output_t *o);

#endif
