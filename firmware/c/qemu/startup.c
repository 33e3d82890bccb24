/* Reset and the vector table for the nRF51 (Cortex-M0): copy .data, zero .bss, run main.
 * No interrupt is ever taken (the port sleeps in WFI with PRIMASK set); a fault ends the
 * run through semihosting with exit status 1, so the host sees it. */
#include <stdint.h>

#include "semihost.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);

void reset_handler(void)
{
    uint32_t *src = &_sidata, *dst = &_sdata;
    while (dst < &_edata) {
        *dst++ = *src++;
    }
    for (dst = &_sbss; dst < &_ebss; dst++) {
        *dst = 0;
    }
    main();
    sh_exit(0);
}

void fault_handler(void)
{
    sh_exit(1);
}

__attribute__((section(".vectors"), used)) static void (*const vectors[16 + 32])(void) = {
    (void (*)(void))(uintptr_t)&_estack,
    reset_handler,
    fault_handler, /* NMI */
    fault_handler, /* HardFault */
    [4 ... 47] = fault_handler,
};
