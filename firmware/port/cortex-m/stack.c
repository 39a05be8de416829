/*
 * stack.c - stack painting: fill the free stack with a pattern, later find the lowest word that
 * changed. The images use no interrupts, so only the code under test writes below SP.
 */
#include <stdint.h>

#include "caekf_port.h"

#define PAINT 0xC5A3E1F7u

extern uint32_t __stack_limit[];
extern uint32_t __StackTop[];

static uintptr_t current_sp(void)
{
    uintptr_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    return sp;
}

/* noinline: the returned SP must be this frame's, which sits just below the caller's. */
__attribute__((noinline)) uintptr_t caekf_stack_paint(void)
{
    uintptr_t sp = current_sp() & ~(uintptr_t)3u;
    volatile uint32_t *p = (volatile uint32_t *)(uintptr_t)__stack_limit;
    while ((uintptr_t)p < sp) {
        *p++ = PAINT;
    }
    return sp;
}

size_t caekf_stack_used_since(uintptr_t top)
{
    const volatile uint32_t *p = (const volatile uint32_t *)(uintptr_t)__stack_limit;
    while ((uintptr_t)p < top && *p == PAINT) {
        ++p;
    }
    return (size_t)(top - (uintptr_t)p);
}

size_t caekf_stack_size(void) { return (size_t)((uintptr_t)__StackTop - (uintptr_t)__stack_limit); }
