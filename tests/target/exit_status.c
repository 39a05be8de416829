/* exit_status.c - main's return value must become QEMU's exit status (expected: 42). */
#include "caekf_port.h"

int main(void)
{
    caekf_console_puts("exit_status: returning 42\n");
    return 42;
}
