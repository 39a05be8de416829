/*
 * smoke.c - proves the toolchain, startup and QEMU path without the estimator: FPU enabled (float
 * and double arithmetic, sqrt), .data copied, .bss zeroed, constructors-free C runtime, semihosting
 * console and exit status (0 here; see exit_status.c for a non-zero one).
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "caekf_port.h"

static volatile double vd = 2.0;
static volatile float vf = 2.0f;
static uint32_t data_word = 0xCAEC0DE5u;
static uint32_t bss_words[16];

static int check(int ok, const char *what)
{
    caekf_console_puts(ok ? "  ok   " : "  FAIL ");
    caekf_console_puts(what);
    caekf_console_putc('\n');
    return ok ? 0 : 1;
}

int main(void)
{
    int fails = 0;
    unsigned i;
    int bss_zero = 1;
    double d = sqrt(vd);
    float f = sqrtf(vf);
    const double d_ref = 1.4142135623730951;
    double third = 1.0 / 3.0;
    uint64_t bits;

    caekf_console_puts("smoke: " CAEKF_SMOKE_MCU "\n");
    for (i = 0; i < sizeof bss_words / sizeof bss_words[0]; ++i) {
        bss_zero &= bss_words[i] == 0u;
    }
    fails += check(data_word == 0xCAEC0DE5u, ".data initialised");
    fails += check(bss_zero, ".bss zeroed");
    fails += check(d == d_ref, "double sqrt(2) exact");
    fails += check(f == 1.41421353816986083984375f, "float sqrtf(2) exact");
    memcpy(&bits, &third, sizeof bits);
    fails += check(bits == 0x3FD5555555555555ull, "double 1/3 bit pattern");
    fails += check(caekf_stack_size() >= 4096u, "stack reserved");
    caekf_console_puts("  sqrt(2) = ");
    caekf_console_put_f64(d, 17);
    caekf_console_puts(" bits ");
    caekf_console_put_f64_bits(d);
    caekf_console_puts("\n  sqrtf(2) = ");
    caekf_console_put_f64((double)f, 9);
    caekf_console_putc('\n');
    caekf_console_puts(fails == 0 ? "smoke: ok\n" : "smoke: FAILED\n");
    return fails;
}
