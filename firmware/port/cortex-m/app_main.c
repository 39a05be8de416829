/*
 * app_main.c - the caekf firmware image for an STM32F4/F7 part with bxCAN (image caekf_fw):
 * board bring-up, SysTick microsecond clock, CAN1 at 1 Mbit/s with the protocol's receive filters,
 * the caekf app in the production profile, and the main loop polling it.
 *
 * It builds in the cortex-m4f / cortex-m7 presets (so size and stack are measured with the real
 * code paths), but it is linked with the port's QEMU mps2 linker script and QEMU's mps2 machines
 * have no bxCAN: it is not run there. tests/unit/port/fw_selftest.c runs the same code against a
 * simulated bxCAN under QEMU instead. For a board:
 *   - a linker script for its memory (e.g. STM32F407: flash 0x08000000, 128 KB SRAM at 0x20000000;
 *     the mps2 script puts the stack at the top of 4 MB of RAM);
 *   - caekf_board_init() (weak, overridable): clocks and pins. The default here keeps the reset
 *     clock (16 MHz HSI: core, AHB and APB1 all 16 MHz), enables the GPIOB and CAN1 clocks and puts
 *     PB8/PB9 on AF9 (CAN1_RX/CAN1_TX, as on Nucleo-F4/F7 boards). A board running the PLL
 *     overrides it and sets CAEKF_FW_CORE_HZ / CAEKF_FW_APB1_HZ to match;
 *   - semihosting is only used by the fault handler of the port (a debugger must be attached for it).
 */
#include <stdint.h>

#include "bxcan.h"
#include "mcu_hal.h"
#include "us_clock.h"

#ifndef CAEKF_FW_CORE_HZ
#define CAEKF_FW_CORE_HZ 16000000u /* SysTick counts the processor clock */
#endif
#ifndef CAEKF_FW_APB1_HZ
#define CAEKF_FW_APB1_HZ 16000000u /* bxCAN's kernel clock */
#endif
/* Bit timing (caekf_bxcan_timing_compute: the most time quanta per bit, 8..25, that divide the clock,
 * sample point nearest CAEKF_FW_SAMPLE_PERMILLE, SJW 1):
 *   APB1 16 MHz (reset HSI, the default here), 1 Mbit/s: BRP 1, 16 tq = 1 + TS1 13 + TS2 2, sample 87.5 %
 *   APB1 42 MHz (F4 at 168 MHz),               1 Mbit/s: BRP 3, 14 tq = 1 + TS1 11 + TS2 2, sample 85.7 %
 *   APB1 54 MHz (F7 at 216 MHz),               1 Mbit/s: BRP 3, 18 tq = 1 + TS1 15 + TS2 2, sample 88.9 %
 * (tests/unit/port/test_bxcan.c checks these). CiA 301 recommends 87.5 % at 1 Mbit/s (75-90 % usable). */
#ifndef CAEKF_FW_BITRATE
#define CAEKF_FW_BITRATE 1000000u
#endif
#ifndef CAEKF_FW_SAMPLE_PERMILLE
#define CAEKF_FW_SAMPLE_PERMILLE 875u
#endif
/* The protocol profile on the wire: PRODUCTION (BENCH_U + BENCH_YP in, EST_PROD + EST_PAGE pages out: 48 % of
 * 1 Mbit/s at 1 kHz) fits a real bus; CAEKF_PROFILE_DIAGNOSTICS (15 frames per step) does not. */
#ifndef CAEKF_FW_PROFILE
#define CAEKF_FW_PROFILE CAEKF_PROFILE_PRODUCTION
#endif
/* Runtime CAN ID base (caekf_app_config_t.id_offset): every ID of caekf.dbc moved by this, for a bus that
 * already uses them; the receive filters follow. */
#ifndef CAEKF_FW_ID_OFFSET
#define CAEKF_FW_ID_OFFSET 0
#endif

/* STM32F4/F7 RCC and GPIOB (same addresses on both families). */
#define RCC_AHB1ENR (*(volatile uint32_t *)0x40023830u)
#define RCC_APB1ENR (*(volatile uint32_t *)0x40023840u)
#define RCC_AHB1ENR_GPIOBEN (1u << 1)
#define RCC_APB1ENR_CAN1EN (1u << 25)
#define GPIOB_MODER (*(volatile uint32_t *)0x40020400u)
#define GPIOB_AFRH (*(volatile uint32_t *)0x40020424u)
#define GPIO_MODE_AF 2u
#define GPIO_AF9_CAN1 9u

void caekf_board_init(void);

__attribute__((weak)) void caekf_board_init(void)
{
    RCC_AHB1ENR |= RCC_AHB1ENR_GPIOBEN;
    RCC_APB1ENR |= RCC_APB1ENR_CAN1EN;
    (void)RCC_APB1ENR; /* read back: the clock is on before the first peripheral access */
    GPIOB_MODER = (GPIOB_MODER & ~((3u << 16) | (3u << 18))) | (GPIO_MODE_AF << 16) | (GPIO_MODE_AF << 18);
    GPIOB_AFRH = (GPIOB_AFRH & ~0xFFu) | (GPIO_AF9_CAN1 << 0) | (GPIO_AF9_CAN1 << 4);
}

static caekf_mcu_fw_t fw; /* driver, HAL and app state: static, no heap */
static caekf_us_clock_t clk;

int main(void)
{
    caekf_mcu_fw_config_t cfg;

    caekf_board_init();
    (void)caekf_us_clock_init(&clk, (caekf_systick_regs_t *)CAEKF_SYSTICK_BASE, CAEKF_FW_CORE_HZ, 1);

    (void)caekf_mcu_fw_config_default(&cfg);
    cfg.regs = (caekf_bxcan_regs_t *)CAEKF_BXCAN1_BASE;
    cfg.filter_regs = cfg.regs; /* CAN1 is the master: its filter banks 0.. */
    cfg.now = caekf_us_clock_now_cb;
    cfg.now_ctx = &clk;
    cfg.app.profile = (uint8_t)CAEKF_FW_PROFILE;
    cfg.app.id_offset = (int16_t)CAEKF_FW_ID_OFFSET;
    /* wait_hook NULL: each acknowledge wait is CAEKF_BXCAN_DEFAULT_WAIT_LIMIT register reads */
    if (caekf_bxcan_timing_compute(CAEKF_FW_APB1_HZ, CAEKF_FW_BITRATE, CAEKF_FW_SAMPLE_PERMILLE, &cfg.can.timing) !=
        CAEKF_BXCAN_OK) {
        return 1;
    }

    /* Until the controller sees the bus idle (11 recessive bits) init reports a start timeout:
     * retry, keeping the clock read often enough to stay exact. */
    while (caekf_mcu_fw_init(&fw, &cfg) != CAEKF_MCU_OK) {
        (void)caekf_us_clock_now(&clk);
    }
    for (;;) {
        (void)caekf_mcu_fw_poll(&fw); /* reads the clock every pass */
    }
}
