/*
 * fw_selftest.c - image caekf_fw_selftest: the firmware of app_main.c (caekf_mcu_fw_*: bxCAN driver,
 * filters, HAL, app) run under QEMU against a bxCAN simulated in RAM (mcu_selftest.h), with the
 * SysTick microsecond clock of the real image. Exit status 0 when every check passed. A test, hence
 * in tests/unit/port, not in firmware/.
 *
 * First it checks the SysTick clock against the semihosting host clock (SYS_CLOCK, centiseconds):
 * over ~0.3 s both must agree within a factor of 8 (a wrong clock source or frequency is off by
 * 25x or more; QEMU's virtual clock follows real time without -icount, but a loaded host stretches
 * the semihosting round trips, which has put a correct clock off by more than 2x).
 */
#include <stddef.h>
#include <stdint.h>

#include "caekf_port.h"
#include "mcu_selftest.h"
#include "us_clock.h"

#ifndef CAEKF_SELFTEST_CORE_HZ
#define CAEKF_SELFTEST_CORE_HZ 25000000u /* QEMU mps2-an386 / an500 system clock */
#endif
#ifndef CAEKF_SELFTEST_MCU
#define CAEKF_SELFTEST_MCU "cortex-m"
#endif
#define SELFTEST_STEPS 8u
#define SEMIHOST_SYS_CLOCK 0x10

static caekf_mcu_selftest_t t; /* the fake controller and the firmware: static, no heap */
static caekf_us_clock_t clk;

static void put_counter(const char *name, uint32_t v)
{
    caekf_console_puts("  ");
    caekf_console_puts(name);
    caekf_console_puts(" = ");
    caekf_console_put_u32(v);
    caekf_console_putc('\n');
}

static int check_clock(void)
{
    int cs0 = caekf_semihost_call(SEMIHOST_SYS_CLOCK, NULL), cs1 = cs0;
    uint32_t us0 = caekf_us_clock_now(&clk), us1 = us0, host_us;
    uint32_t i;
    for (i = 0u; i < 20000000u && cs1 - cs0 < 30; i++) {
        us1 = caekf_us_clock_now(&clk);
        cs1 = caekf_semihost_call(SEMIHOST_SYS_CLOCK, NULL);
    }
    us1 = caekf_us_clock_now(&clk);
    host_us = (uint32_t)(cs1 - cs0) * 10000u;
    caekf_console_puts("  SysTick clock: ");
    caekf_console_put_u32(us1 - us0);
    caekf_console_puts(" us over ");
    caekf_console_put_u32(host_us);
    caekf_console_puts(" us of host clock\n");
    if (cs0 < 0 || host_us == 0u) {
        caekf_console_puts("  FAIL semihosting SYS_CLOCK unavailable\n");
        return 1;
    }
    if ((us1 - us0) < host_us / 8u || (us1 - us0) > host_us * 8u) {
        caekf_console_puts("  FAIL SysTick microseconds disagree with the host clock\n");
        return 1;
    }
    return 0;
}

int main(void)
{
    int fails = 0;
    uint32_t t0, t1;

    caekf_console_puts("fw selftest: " CAEKF_SELFTEST_MCU ", bxCAN simulated in RAM\n");
    if (caekf_us_clock_init(&clk, (caekf_systick_regs_t *)CAEKF_SYSTICK_BASE, CAEKF_SELFTEST_CORE_HZ, 1) != 0) {
        caekf_console_puts("  FAIL clock init\n");
        return 1;
    }
    fails += check_clock();

    caekf_mcu_selftest_prepare(&t);
    t0 = caekf_us_clock_now(&clk);
    if (caekf_mcu_selftest_run(&t, caekf_us_clock_now_cb, &clk, SELFTEST_STEPS) != 0) {
        caekf_console_puts("  FAIL ");
        caekf_console_puts(t.failure != 0 ? t.failure : "(no reason)");
        caekf_console_puts(" (value ");
        caekf_console_put_i32((int32_t)t.failure_value);
        caekf_console_puts(")\n");
        fails++;
    }
    t1 = caekf_us_clock_now(&clk);
    put_counter("steps estimated", t.steps_ok);
    put_counter("frames into RX FIFO 0", t.frames_in);
    put_counter("frames out of the TX mailboxes", t.frames_out);
    put_counter("frames rejected by the filters", t.fake.rx_filtered);
    put_counter("driver rx_frames", t.fw.can.cnt.rx_frames);
    put_counter("driver rx_overruns", t.fw.can.cnt.rx_overruns);
    put_counter("driver tx_ok", t.fw.can.cnt.tx_ok);
    put_counter("driver tx_busy", t.fw.can.cnt.tx_busy);
    put_counter("hal tx queue high water", t.fw.hal.cnt.txq_high_water);
    put_counter("run time (us)", t1 - t0);
    caekf_console_puts(fails == 0 ? "fw selftest: ok\n" : "fw selftest: FAILED\n");
    return fails;
}
