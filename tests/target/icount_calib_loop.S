/*
 * icount_calib_loop.S - a measured region of exactly known length for tools/qemu-icount.
 *
 * void calib_run(uint32_t n), n >= 1: between entering caekf_mark_begin and entering
 * caekf_mark_end it executes  1 (bx lr of caekf_mark_begin) + 2n (subs/bne loop) + 1 (bl)
 * = 2n + 2 instructions.
 */
    .syntax unified
    .thumb
    .section .text.calib_run, "ax", %progbits
    .global calib_run
    .type calib_run, %function
    .thumb_func
calib_run:
    push    {r4, lr}
    mov     r4, r0
    bl      caekf_mark_begin
1:  subs    r4, r4, #1
    bne     1b
    bl      caekf_mark_end
    pop     {r4, pc}
    .size calib_run, . - calib_run
