/*
 * semihost.c - Arm semihosting: console output and exit with a status.
 *
 * Console: the host's stdout opened as ":tt" (SYS_OPEN mode "w"), written with SYS_WRITE from a
 * line buffer; if the open fails, SYS_WRITE0 is used. Exit: SYS_EXIT_EXTENDED with
 * ADP_Stopped_ApplicationExit and the status (plain SYS_EXIT carries no status on 32-bit Arm);
 * QEMU then exits with that status.
 */
#include <stdint.h>
#include <string.h>

#include "caekf_port.h"

#define SYS_OPEN 0x01
#define SYS_WRITE 0x05
#define SYS_WRITE0 0x04
#define SYS_EXIT 0x18
#define SYS_EXIT_EXTENDED 0x20
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u
#define OPEN_MODE_W 4 /* "w" */

int caekf_semihost_call(int op, const void *arg)
{
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

#define CONSOLE_BUF 256
static char console_buf[CONSOLE_BUF + 1]; /* +1: NUL for the SYS_WRITE0 fallback */
static size_t console_len;
static int console_handle = -2; /* -2: not opened yet, -1: open failed */

static void console_open(void)
{
    static const char tt[] = ":tt";
    uint32_t args[3];
    args[0] = (uint32_t)(uintptr_t)tt;
    args[1] = OPEN_MODE_W;
    args[2] = (uint32_t)(sizeof tt - 1u);
    console_handle = caekf_semihost_call(SYS_OPEN, args);
    if (console_handle < 0) {
        console_handle = -1;
    }
}

void caekf_console_flush(void)
{
    if (console_len == 0u) {
        return;
    }
    if (console_handle == -2) {
        console_open();
    }
    if (console_handle >= 0) {
        uint32_t args[3];
        args[0] = (uint32_t)console_handle;
        args[1] = (uint32_t)(uintptr_t)console_buf;
        args[2] = (uint32_t)console_len;
        (void)caekf_semihost_call(SYS_WRITE, args);
    } else {
        /* SYS_WRITE0 stops at a NUL: write the buffer in NUL-free pieces. */
        size_t i = 0u;
        console_buf[console_len] = '\0';
        while (i < console_len) {
            size_t n = strlen(console_buf + i);
            if (n > 0u) {
                (void)caekf_semihost_call(SYS_WRITE0, console_buf + i);
            }
            i += n + 1u;
        }
    }
    console_len = 0u;
}

void caekf_console_putc(int c)
{
    console_buf[console_len++] = (char)c;
    if (c == '\n' || console_len == CONSOLE_BUF) {
        caekf_console_flush();
    }
}

void caekf_console_write(const char *s, size_t n)
{
    size_t i;
    for (i = 0u; i < n; ++i) {
        caekf_console_putc((unsigned char)s[i]);
    }
}

void caekf_console_puts(const char *s)
{
    while (*s != '\0') {
        caekf_console_putc((unsigned char)*s++);
    }
}

void caekf_console_put_u32(uint32_t v)
{
    char tmp[10];
    int n = 0;
    do {
        tmp[n++] = (char)('0' + (int)(v % 10u));
        v /= 10u;
    } while (v != 0u);
    while (n > 0) {
        caekf_console_putc(tmp[--n]);
    }
}

void caekf_console_put_i32(int32_t v)
{
    if (v < 0) {
        caekf_console_putc('-');
        caekf_console_put_u32((uint32_t)(-(v + 1)) + 1u);
    } else {
        caekf_console_put_u32((uint32_t)v);
    }
}

static void put_hex(uint64_t v, int digits)
{
    static const char hex[] = "0123456789abcdef";
    int i;
    for (i = digits - 1; i >= 0; --i) {
        caekf_console_putc(hex[(unsigned)(v >> (4 * i)) & 0xFu]);
    }
}

void caekf_console_put_hex32(uint32_t v) { put_hex(v, 8); }

void caekf_console_put_f64_bits(double v)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    put_hex(bits, 16);
}

void caekf_console_put_f64(double v, int sig)
{
    int exp10 = 0;
    int i;
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    if (sig < 1) {
        sig = 1;
    } else if (sig > 17) {
        sig = 17;
    }
    if (((bits >> 52) & 0x7FFu) == 0x7FFu) {
        caekf_console_puts((bits & 0xFFFFFFFFFFFFFull) != 0u ? "nan" : ((bits >> 63) != 0u ? "-inf" : "inf"));
        return;
    }
    if ((bits >> 63) != 0u) {
        caekf_console_putc('-');
        v = -v;
    }
    if (v != 0.0) {
        while (v >= 10.0) {
            v /= 10.0;
            ++exp10;
        }
        while (v < 1.0) {
            v *= 10.0;
            --exp10;
        }
        /* round to `sig` digits */
        {
            double half = 0.5;
            for (i = 1; i < sig; ++i) {
                half /= 10.0;
            }
            v += half;
            if (v >= 10.0) {
                v /= 10.0;
                ++exp10;
            }
        }
    }
    for (i = 0; i < sig; ++i) {
        int d = (int)v;
        if (d > 9) {
            d = 9;
        }
        caekf_console_putc('0' + d);
        if (i == 0 && sig > 1) {
            caekf_console_putc('.');
        }
        v = (v - (double)d) * 10.0;
    }
    caekf_console_putc('e');
    if (exp10 < 0) {
        caekf_console_putc('-');
        exp10 = -exp10;
    } else {
        caekf_console_putc('+');
    }
    if (exp10 < 10) {
        caekf_console_putc('0');
    }
    caekf_console_put_u32((uint32_t)exp10);
}

void caekf_port_exit(int status)
{
    uint32_t block[2];
    caekf_console_flush();
    block[0] = ADP_STOPPED_APPLICATION_EXIT;
    block[1] = (uint32_t)status;
    (void)caekf_semihost_call(SYS_EXIT_EXTENDED, block);
    /* Semihosting without the extension: plain exit (status lost). */
    (void)caekf_semihost_call(SYS_EXIT, (const void *)(uintptr_t)ADP_STOPPED_APPLICATION_EXIT);
    for (;;) {
        __asm__ volatile("wfi");
    }
}
