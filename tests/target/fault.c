/* fault.c - an undefined instruction must end the run with CAEKF_PORT_EXIT_FAULT (64), not hang. */
#include "caekf_port.h"

int main(void)
{
    caekf_console_puts("fault: executing an undefined instruction\n");
    __asm__ volatile("udf #0");
    caekf_console_puts("fault: still running?\n");
    return 0;
}
