/*
 * fw_selftest.c - image caekf_fw_selftest: the firmware of app_main.c (caekf_mcu_fw_*: bxCAN driver,
 * filters, HAL, app) run under QEMU against a bxCAN simulated in RAM (mcu_selftest.h), with the
 * SysTick microsecond clock of the real image. Exit status 0 when every check passed. A test, hence
 * in tests/unit/port, not in firmware/.
 *
 * First it checks the SysTick clock against the semihosting host wall clock (SYS_TIME, from one second
 * boundary to the next): within a factor of 2 (a wrong clock source or frequency is off by 25x or more;
 * QEMU's virtual clock follows real time without -icount). SYS_CLOCK is not used: QEMU answers it
 * with its own CPU time, which falls behind the wall clock on a loaded machine.
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
#define SELFTEST_STEPS 8u      /* per profile: diagnostics, then production */
#define SEMIHOST_SYS_TIME 0x11 /* host wall clock, whole seconds (SYS_CLOCK would be QEMU's CPU time) */
#define SEMIHOST_WAIT_LIMIT 20000000u

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

/* Waits for the host's wall-clock second to change; returns the SysTick microseconds at that moment. */
static int next_second(int *sec, uint32_t *us)
{
    uint32_t i;
    for (i = 0u; i < SEMIHOST_WAIT_LIMIT; i++) {
        int s = caekf_semihost_call(SEMIHOST_SYS_TIME, NULL);
        *us = caekf_us_clock_now(&clk); /* read often: the clock stays exact */
        if (s != *sec) {
            *sec = s;
            return 0;
        }
    }
    return -1;
}

/* SysTick microseconds over one second of the host's wall clock (second boundary to second boundary).
 * Both are wall time (QEMU's SysTick follows real time without -icount), so a loaded machine does not
 * matter; the factor 2 only catches a wrong clock setting (e.g. the 25 MHz taken as 12.5 or 50). */
static int check_clock(void)
{
    int sec = caekf_semihost_call(SEMIHOST_SYS_TIME, NULL);
    uint32_t us0 = 0u, us1 = 0u;
    if (sec <= 0) {
        caekf_console_puts("  FAIL semihosting SYS_TIME unavailable\n");
        return 1;
    }
    if (next_second(&sec, &us0) != 0 || next_second(&sec, &us1) != 0) {
        caekf_console_puts("  FAIL the host clock did not advance\n");
        return 1;
    }
    caekf_console_puts("  SysTick clock: ");
    caekf_console_put_u32(us1 - us0);
    caekf_console_puts(" us over 1 s of the host's wall clock\n");
    if ((us1 - us0) < 500000u || (us1 - us0) > 2000000u) {
        caekf_console_puts("  FAIL SysTick microseconds disagree with the host clock\n");
        return 1;
    }
    return 0;
}

/* The self-test sequence with the firmware and the bench in one profile (SELFTEST_STEPS steps each). */
static int run_profile(caekf_profile_t profile, const char *name)
{
    int fails = 0;
    uint32_t t0, t1;
    caekf_console_puts(" profile ");
    caekf_console_puts(name);
    caekf_console_putc('\n');
    caekf_mcu_selftest_prepare(&t);
    t.profile = (uint8_t)profile;
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
    return fails;
}

int main(void)
{
    int fails = 0;

    caekf_console_puts("fw selftest: " CAEKF_SELFTEST_MCU ", bxCAN simulated in RAM\n");
    if (caekf_us_clock_init(&clk, (caekf_systick_regs_t *)CAEKF_SYSTICK_BASE, CAEKF_SELFTEST_CORE_HZ, 1) != 0) {
        caekf_console_puts("  FAIL clock init\n");
        return 1;
    }
    fails += check_clock();

    fails += run_profile(CAEKF_PROFILE_DIAGNOSTICS, "diagnostics");
    fails += run_profile(CAEKF_PROFILE_PRODUCTION, "production");
    caekf_console_puts(fails == 0 ? "fw selftest: ok\n" : "fw selftest: FAILED\n");
    return fails;
}
