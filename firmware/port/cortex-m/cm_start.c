/*
 * cm_start.c - vector table, C runtime start and fault handlers for the Cortex-M images.
 *
 * Reset_Handler (startup.S) enables the FPU and calls caekf_port_c_start(): copy .data, zero .bss,
 * run constructors (.init_array), call main(), exit through semihosting with main's return value.
 * Every fault or unexpected exception prints what it can and exits with CAEKF_PORT_EXIT_FAULT, so a
 * crashing image ends the QEMU run instead of hanging it.
 */
#include <stdint.h>

#include "caekf_port.h"

extern uint32_t __StackTop[];
extern uint32_t __data_start[], __data_end[], __data_load[];
extern uint32_t __bss_start[], __bss_end[];
typedef void (*caekf_vector_t)(void);
extern caekf_vector_t __init_array_start[], __init_array_end[];

extern int main(void);
void Reset_Handler(void);
void caekf_port_c_start(void) __attribute__((noreturn));
void caekf_fault_report(const uint32_t *frame, uint32_t exc_return) __attribute__((noreturn));

static void fault_entry(void);

#define CAEKF_NUM_IRQ 32

/* Vector table: initial SP, Reset_Handler, the 14 system exceptions, then the external interrupts
 * (none is ever enabled by the images; all go to fault_entry). */
typedef struct {
    /* cppcheck-suppress unusedStructMember ; read by the hardware (the vector table) */
    uint32_t *initial_sp;
    /* cppcheck-suppress unusedStructMember ; read by the hardware (the vector table) */
    caekf_vector_t handlers[15 + CAEKF_NUM_IRQ];
} caekf_vector_table_t;

#define FE fault_entry
// clang-format off
__attribute__((section(".isr_vector"), used)) static const caekf_vector_table_t caekf_vectors = {
    __StackTop,
    {
        Reset_Handler,
        FE, /* NMI */
        FE, /* HardFault */
        FE, /* MemManage */
        FE, /* BusFault */
        FE, /* UsageFault */
        0, 0, 0, 0, /* reserved */
        FE, /* SVCall */
        FE, /* DebugMonitor */
        0,  /* reserved */
        FE, /* PendSV */
        FE, /* SysTick */
        FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE,
        FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE, FE,
    }
};
// clang-format on
#undef FE

void caekf_port_c_start(void)
{
    const uint32_t *src = __data_load;
    uint32_t *dst;
    caekf_vector_t *ctor;

    /* cppcheck-suppress comparePointers ; linker-script symbols bounding one section */
    for (dst = __data_start; dst < __data_end; ++dst, ++src) {
        *dst = *src;
    }
    /* cppcheck-suppress comparePointers ; linker-script symbols bounding one section */
    for (dst = __bss_start; dst < __bss_end; ++dst) {
        *dst = 0u;
    }
    /* cppcheck-suppress comparePointers ; linker-script symbols bounding one section */
    for (ctor = __init_array_start; ctor < __init_array_end; ++ctor) {
        (*ctor)();
    }
    caekf_port_exit(main());
}

/* Fault entry: find the stacked exception frame (MSP or PSP per EXC_RETURN bit 2) and report. */
__attribute__((naked)) static void fault_entry(void)
{
    __asm__ volatile("tst   lr, #4          \n"
                     "ite   eq              \n"
                     "mrseq r0, msp         \n"
                     "mrsne r0, psp         \n"
                     "mov   r1, lr          \n"
                     "b     caekf_fault_report\n");
}

void caekf_fault_report(const uint32_t *frame, uint32_t exc_return)
{
    volatile const uint32_t *const icsr = (volatile const uint32_t *)0xE000ED04u;
    volatile const uint32_t *const cfsr = (volatile const uint32_t *)0xE000ED28u;
    volatile const uint32_t *const hfsr = (volatile const uint32_t *)0xE000ED2Cu;
    volatile const uint32_t *const bfar = (volatile const uint32_t *)0xE000ED38u;

    caekf_console_puts("\n*** caekf port: exception ");
    caekf_console_put_u32(*icsr & 0x1FFu);
    caekf_console_puts(" pc=0x");
    caekf_console_put_hex32(frame[6]);
    caekf_console_puts(" lr=0x");
    caekf_console_put_hex32(frame[5]);
    caekf_console_puts(" exc_return=0x");
    caekf_console_put_hex32(exc_return);
    caekf_console_puts(" cfsr=0x");
    caekf_console_put_hex32(*cfsr);
    caekf_console_puts(" hfsr=0x");
    caekf_console_put_hex32(*hfsr);
    caekf_console_puts(" bfar=0x");
    caekf_console_put_hex32(*bfar);
    caekf_console_puts("\n");
    caekf_port_exit(CAEKF_PORT_EXIT_FAULT);
}
