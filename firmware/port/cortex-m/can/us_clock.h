/*
 * us_clock.h - a free-running microsecond clock from the Cortex-M SysTick timer, without interrupts.
 *
 * SysTick counts down from RVR to 0 and reloads; we run it over its full 24-bit range and, on every
 * caekf_us_clock_now(), add the cycles elapsed since the previous reading (modulo 2^24) and convert
 * whole microseconds. No SysTick interrupt is needed (the port's vector table routes SysTick to the
 * fault handler), and the result is exact as long as readings are less than 2^24 timer cycles
 * apart: 99.8 ms at 168 MHz, 77.6 ms at 216 MHz, 671 ms at QEMU mps2's 25 MHz. The caekf app reads
 * the time on every caekf_app_poll, so a main loop that polls continuously keeps it exact; a loop
 * that sleeps longer must read the clock at least that often (or use a DWT/timer source instead).
 *
 * The SysTick registers are an overlay at a caller-given address (CAEKF_SYSTICK_BASE on the part),
 * so the tests run it on a RAM block. The counter arithmetic is caekf_us_clock_advance(), which
 * takes a raw reading and is tested on its own.
 *
 * On QEMU (mps2-an386 / an500, QEMU >= 6) SysTick's processor clock is the board's 25 MHz system
 * clock in virtual time, which follows the host's real time when QEMU runs without -icount.
 */
#ifndef CAEKF_US_CLOCK_H
#define CAEKF_US_CLOCK_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define CAEKF_SYSTICK_BASE 0xE000E010u

typedef struct {
    volatile uint32_t CSR;   /* 0x0 control and status: ENABLE 0, TICKINT 1, CLKSOURCE 2, COUNTFLAG 16 */
    volatile uint32_t RVR;   /* 0x4 reload value (24 bits) */
    volatile uint32_t CVR;   /* 0x8 current value (any write clears it to 0) */
    volatile uint32_t CALIB; /* 0xC calibration (read only) */
} caekf_systick_regs_t;

typedef char caekf_systick_layout_check[(offsetof(caekf_systick_regs_t, CALIB) == 0xCu) ? 1 : -1];

#define CAEKF_SYSTICK_CSR_ENABLE (1u << 0)
#define CAEKF_SYSTICK_CSR_TICKINT (1u << 1)
#define CAEKF_SYSTICK_CSR_CLKSOURCE (1u << 2) /* 1: processor clock, 0: external reference clock */
#define CAEKF_SYSTICK_CSR_COUNTFLAG (1u << 16)
#define CAEKF_SYSTICK_MAX 0x00FFFFFFu

typedef struct {
    caekf_systick_regs_t *st;
    uint32_t cycles_per_us; /* timer clock in MHz */
    uint32_t last;          /* previous raw reading */
    uint32_t cycles;        /* cycles not yet converted (< cycles_per_us) */
    uint32_t us;            /* the clock; wraps modulo 2^32 */
} caekf_us_clock_t;

/* Starts SysTick at full range without interrupt. timer_hz: the clock SysTick counts (the core
 * clock with processor_clock = 1, else the implementation's reference clock); a whole number of MHz,
 * at least 1 MHz. Returns 0, or -1 for a NULL pointer or a bad frequency. */
int caekf_us_clock_init(caekf_us_clock_t *c, caekf_systick_regs_t *st, uint32_t timer_hz, int processor_clock);

/* Reads SysTick and returns the microseconds since init (modulo 2^32). */
uint32_t caekf_us_clock_now(caekf_us_clock_t *c);

/* The arithmetic of caekf_us_clock_now for a raw down-counter reading (no register access). */
uint32_t caekf_us_clock_advance(caekf_us_clock_t *c, uint32_t raw);

/* caekf_app_hal_t-style adapter: ctx is a caekf_us_clock_t. */
uint32_t caekf_us_clock_now_cb(void *ctx);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_US_CLOCK_H */
