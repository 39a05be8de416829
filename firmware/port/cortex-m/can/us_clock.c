/* Interrupt-free microsecond clock from SysTick: see us_clock.h. */
#include "us_clock.h"

int caekf_us_clock_init(caekf_us_clock_t *c, caekf_systick_regs_t *st, uint32_t timer_hz, int processor_clock)
{
    if (c == NULL || st == NULL || timer_hz < 1000000u || timer_hz % 1000000u != 0u) {
        return -1;
    }
    c->st = st;
    c->cycles_per_us = timer_hz / 1000000u;
    c->cycles = 0u;
    c->us = 0u;
    st->CSR = 0u;
    st->RVR = CAEKF_SYSTICK_MAX;
    st->CVR = 0u; /* clears the counter: it reloads RVR on the next timer clock */
    st->CSR = CAEKF_SYSTICK_CSR_ENABLE | (processor_clock ? CAEKF_SYSTICK_CSR_CLKSOURCE : 0u);
    c->last = st->CVR & CAEKF_SYSTICK_MAX;
    return 0;
}

uint32_t caekf_us_clock_advance(caekf_us_clock_t *c, uint32_t raw)
{
    uint32_t elapsed;
    raw &= CAEKF_SYSTICK_MAX;
    /* Down counter over 0..0xFFFFFF: the period is 2^24, so the difference modulo 2^24 is exact. */
    elapsed = (c->last - raw) & CAEKF_SYSTICK_MAX;
    c->last = raw;
    c->cycles += elapsed; /* < 2^24 + cycles_per_us: no overflow */
    c->us += c->cycles / c->cycles_per_us;
    c->cycles %= c->cycles_per_us;
    return c->us;
}

uint32_t caekf_us_clock_now(caekf_us_clock_t *c) { return caekf_us_clock_advance(c, c->st->CVR); }

uint32_t caekf_us_clock_now_cb(void *ctx) { return caekf_us_clock_now((caekf_us_clock_t *)ctx); }
