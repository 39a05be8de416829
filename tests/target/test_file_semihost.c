/*
 * test_file_semihost.c - the MCU side of the unit tests' file access (tests/unit/support/
 * test_support.h): host files read through Arm semihosting (SYS_OPEN / SYS_READ / SYS_CLOSE), with
 * a read-ahead buffer so a record-by-record reader costs one semihosting call per 4 KB.
 * Selected by cmake/Target.cmake as CAEKF_TARGET_TEST_FILE_IO. Paths are host paths (QEMU runs with
 * -semihosting-config target=native and opens them relative to its working directory).
 */
#include <stdint.h>
#include <string.h>

#include "test_support.h"

/* From firmware/port/cortex-m/semihost.c (declared here: this file is compiled into the unit tests'
 * support library, whose include path does not carry the port). */
int caekf_semihost_call(int op, const void *arg);

#define SYS_OPEN 0x01
#define SYS_CLOSE 0x02
#define SYS_READ 0x06
#define OPEN_MODE_RB 1 /* "rb" */
#define READ_AHEAD 4096u

static int handle = -1;
static unsigned char ahead[READ_AHEAD];
static uint32_t ahead_len, ahead_pos;

int test_file_open(const char *path)
{
    uint32_t args[3];
    test_file_close();
    args[0] = (uint32_t)(uintptr_t)path;
    args[1] = OPEN_MODE_RB;
    args[2] = (uint32_t)strlen(path);
    handle = caekf_semihost_call(SYS_OPEN, args);
    ahead_len = ahead_pos = 0u;
    return handle < 0 ? -1 : 0;
}

static int refill(void)
{
    uint32_t args[3];
    int not_read;
    args[0] = (uint32_t)handle;
    args[1] = (uint32_t)(uintptr_t)ahead;
    args[2] = READ_AHEAD;
    not_read = caekf_semihost_call(SYS_READ, args); /* returns the number of bytes NOT read */
    if (not_read < 0 || (uint32_t)not_read > READ_AHEAD) {
        return -1;
    }
    ahead_len = READ_AHEAD - (uint32_t)not_read;
    ahead_pos = 0u;
    return 0;
}

long test_file_read(void *buf, unsigned long n)
{
    unsigned char *out = buf;
    unsigned long done = 0u;
    if (handle < 0) {
        return -1;
    }
    while (done < n) {
        uint32_t avail;
        if (ahead_pos == ahead_len) {
            if (refill() != 0) {
                return -1;
            }
            if (ahead_len == 0u) {
                break; /* end of file */
            }
        }
        avail = ahead_len - ahead_pos;
        if (avail > n - done) {
            avail = (uint32_t)(n - done);
        }
        memcpy(out + done, ahead + ahead_pos, avail);
        ahead_pos += avail;
        done += avail;
    }
    return (long)done;
}

void test_file_close(void)
{
    if (handle >= 0) {
        uint32_t args[1];
        args[0] = (uint32_t)handle;
        (void)caekf_semihost_call(SYS_CLOSE, args);
        handle = -1;
    }
    ahead_len = ahead_pos = 0u;
}
