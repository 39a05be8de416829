/*
 * caekf_port.h - the Cortex-M port: semihosting console and exit, stack painting, and the
 * instruction-count markers. Used by the target images in tests/target/ and by Unity on target
 * (UNITY_OUTPUT_CHAR = caekf_console_putc). Runs on QEMU's mps2-an386 (Cortex-M4F) and
 * mps2-an500 (Cortex-M7) with `-semihosting-config enable=on,target=native`; on a real part a
 * debugger must service the semihosting BKPTs, otherwise they fault.
 *
 * No heap: the port provides no _sbrk, so anything that needs malloc - newlib's stdio, printf of
 * floats, raise() - fails to link. Print with the caekf_console_* functions instead.
 */
#ifndef CAEKF_PORT_H
#define CAEKF_PORT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Exit statuses the port itself uses (main's return value is passed through otherwise). */
#define CAEKF_PORT_EXIT_FAULT 64 /* HardFault, MemManage, BusFault, UsageFault, NMI, stray IRQ */
#define CAEKF_PORT_EXIT_ABORT 65 /* abort() or a failed assert() */

/* ---- semihosting console (buffered; flushed on '\n', when full, and at exit) ---- */
void caekf_console_putc(int c);
void caekf_console_write(const char *s, size_t n);
void caekf_console_puts(const char *s); /* no newline appended */
void caekf_console_flush(void);
void caekf_console_put_u32(uint32_t v);
void caekf_console_put_i32(int32_t v);
void caekf_console_put_hex32(uint32_t v); /* 8 hex digits, no prefix */
/* Exact: the 16 hex digits of the IEEE-754 binary64 bit pattern (no prefix), for machine checks. */
void caekf_console_put_f64_bits(double v);
/* Human-readable scientific notation with `sig` significant digits (1..17). Not correctly rounded
 * in the last digit; use caekf_console_put_f64_bits for comparisons. */
void caekf_console_put_f64(double v, int sig);

/* ---- exit: flushes the console, then semihosting SYS_EXIT_EXTENDED(ApplicationExit, status);
 * QEMU exits with `status`. Also what happens when main() returns. ---- */
void caekf_port_exit(int status) __attribute__((noreturn));

/* Raw semihosting call (BKPT 0xAB): operation number and parameter block. */
int caekf_semihost_call(int op, const void *arg);

/* ---- stack painting ----
 * caekf_stack_paint() fills the free stack [__stack_limit, SP) with a pattern and returns the SP
 * it painted below (the caller's SP, within a few bytes). After running code,
 * caekf_stack_used_since(top) returns how many bytes below `top` were touched (high-water mark).
 * No interrupts are used by the images, so nothing else writes below SP. */
uintptr_t caekf_stack_paint(void);
size_t caekf_stack_used_since(uintptr_t top);
size_t caekf_stack_size(void); /* bytes reserved for the stack by the linker script */

/* ---- markers for tools/qemu-icount (startup.S): the plugin counts instructions executed from
 * entering caekf_mark_begin to entering caekf_mark_end (begin's own 1 instruction included). */
void caekf_mark_begin(void);
void caekf_mark_end(void);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_PORT_H */
