/*
 * stack_selftest.c - proves the stack painting: a function that touches a known amount of stack
 * must be measured at least that deep, and not much deeper.
 */
#include <stddef.h>
#include <stdint.h>

#include "caekf_port.h"

#define DEPTH 3000u

__attribute__((noinline)) static uint32_t touch(uint32_t seed)
{
    volatile uint8_t buf[DEPTH];
    uint32_t i, acc = 0u;
    for (i = 0u; i < DEPTH; ++i) {
        buf[i] = (uint8_t)(seed + i);
    }
    for (i = 0u; i < DEPTH; i += 97u) {
        acc += buf[i];
    }
    return acc;
}

int main(void)
{
    uintptr_t top = caekf_stack_paint();
    size_t idle = caekf_stack_used_since(top);
    size_t used;
    uint32_t r = touch(7u);
    used = caekf_stack_used_since(top);
    caekf_console_puts("stack_selftest: reserved ");
    caekf_console_put_u32((uint32_t)caekf_stack_size());
    caekf_console_puts(" B, idle ");
    caekf_console_put_u32((uint32_t)idle);
    caekf_console_puts(" B, touch(");
    caekf_console_put_u32(DEPTH);
    caekf_console_puts(" B array) measured ");
    caekf_console_put_u32((uint32_t)used);
    caekf_console_puts(" B (checksum ");
    caekf_console_put_u32(r);
    caekf_console_puts(")\n");
    if (idle > 16u || used < DEPTH || used > DEPTH + 64u) {
        caekf_console_puts("stack_selftest: FAILED\n");
        return 1;
    }
    caekf_console_puts("stack_selftest: ok\n");
    return 0;
}
