/* hang.c - never exits: tools/qemu-run.sh must kill it at its timeout (status 124). */
#include "caekf_port.h"

int main(void)
{
    volatile int forever = 1;
    caekf_console_puts("hang: spinning\n");
    while (forever) {
    }
    return 0;
}
