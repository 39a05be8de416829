/*
 * icount_calib.c - proves tools/qemu-icount on an image whose counts are known exactly: each
 * calib_run(n) is one interval of 2n + 2 instructions (see icount_calib_loop.S). The expected
 * counts are printed as "expect: ..." for tools/qemu-icount/icount-run.py --expect-from-output.
 */
#include <stdint.h>

#include "caekf_port.h"

void calib_run(uint32_t n);

static const uint32_t loops[] = {1u, 10u, 1000u, 100000u, 7u};

int main(void)
{
    unsigned i;
    caekf_console_puts("expect:");
    for (i = 0; i < sizeof loops / sizeof loops[0]; ++i) {
        caekf_console_putc(' ');
        caekf_console_put_u32(2u * loops[i] + 2u);
    }
    caekf_console_putc('\n');
    for (i = 0; i < sizeof loops / sizeof loops[0]; ++i) {
        calib_run(loops[i]);
    }
    caekf_console_puts("icount_calib: done\n");
    return 0;
}
