/*
 * startup.S - reset entry for the Cortex-M images, and the instruction-count markers.
 *
 * Reset_Handler runs before any C: it sets MSP from the linker script (QEMU's loader already did,
 * real parts do it from vector 0; doing it again is harmless), grants CP10/CP11 full access in
 * CPACR when the build uses the FPU (CPACR is 0 at reset: the first VFP instruction would fault),
 * then hands over to caekf_port_c_start() in cm_start.c (.data copy, .bss zero, main, exit).
 */
    .syntax unified
    .thumb

    .section .text.Reset_Handler, "ax", %progbits
    .global Reset_Handler
    .type Reset_Handler, %function
    .thumb_func
Reset_Handler:
    ldr     r0, =__StackTop
    msr     msp, r0
#if defined(__ARM_FP)
    ldr     r0, =0xE000ED88         /* SCB->CPACR */
    ldr     r1, [r0]
    orr     r1, r1, #(0xF << 20)    /* CP10, CP11: full access */
    str     r1, [r0]
    dsb
    isb
#endif
    bl      caekf_port_c_start
1:  b       1b                      /* not reached: caekf_port_c_start exits */
    .size Reset_Handler, . - Reset_Handler
    .pool

/*
 * Marker functions for tools/qemu-icount: the plugin counts the instructions executed from
 * entering caekf_mark_begin to entering caekf_mark_end. Written here (not in C) so that the
 * compiler can neither inline nor merge them (identical code folding), and so their instruction
 * counts are fixed: begin = 1 instruction (bx lr), end = 2 (nop; bx lr).
 */
    .section .text.caekf_mark_begin, "ax", %progbits
    .global caekf_mark_begin
    .type caekf_mark_begin, %function
    .thumb_func
caekf_mark_begin:
    bx      lr
    .size caekf_mark_begin, . - caekf_mark_begin

    .section .text.caekf_mark_end, "ax", %progbits
    .global caekf_mark_end
    .type caekf_mark_end, %function
    .thumb_func
caekf_mark_end:
    nop
    bx      lr
    .size caekf_mark_end, . - caekf_mark_end
