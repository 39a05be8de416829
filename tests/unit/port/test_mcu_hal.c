/*
 * Unity tests of the MCU side of the app HAL (firmware/port/cortex-m/can/mcu_hal.c), the SysTick
 * microsecond clock (us_clock.c) and the firmware selftest (mcu_selftest.c), over the simulated bxCAN.
 */
#include <stddef.h>
#include <string.h>

#include "bxcan_fake.h"
#include "mcu_hal.h"
#include "mcu_selftest.h"
#include "unity.h"
#include "us_clock.h"

static caekf_bxcan_fake_t fake;
static caekf_bxcan_t can;
static caekf_mcu_hal_t hal;
static caekf_app_hal_t app_hal;
static uint32_t fake_now;
static caekf_mcu_selftest_t st;

static uint32_t now_cb(void *ctx)
{
    (void)ctx;
    fake_now += 50u; /* every reading 50 us later */
    return fake_now;
}

void setUp(void)
{
    caekf_bxcan_config_t cfg;
    caekf_bxcan_fake_reset(&fake);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_config_default(&cfg));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_timing_compute(42000000u, 500000u, 875u, &cfg.timing));
    cfg.wait_hook = caekf_bxcan_fake_hook;
    cfg.wait_ctx = &fake;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_init(&can, &fake.regs, &cfg));
    TEST_ASSERT_EQUAL_INT(0, caekf_mcu_hal_init(&hal, &can, now_cb, NULL));
    memset(&app_hal, 0, sizeof app_hal);
    caekf_mcu_hal_bind(&hal, &app_hal);
    fake_now = 0xFFFFFF00u;
}

void tearDown(void) {}

static caekf_bxcan_frame_t bx(uint32_t id, uint8_t ide, uint8_t rtr, uint8_t dlc)
{
    caekf_bxcan_frame_t f;
    unsigned i;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.ide = ide;
    f.rtr = rtr;
    f.dlc = dlc;
    for (i = 0; i < 8u; i++) {
        f.data[i] = (uint8_t)(0xA0u + i);
    }
    return f;
}

/* One 32-bit mask filter accepting everything (bank 0, FIFO 0). */
static void accept_all(void)
{
    fake.regs.FMR |= CAEKF_BXCAN_FMR_FINIT;
    fake.regs.FS1R |= 1u;
    fake.regs.FM1R &= ~1u;
    fake.regs.filter[0].FR1 = 0u;
    fake.regs.filter[0].FR2 = 0u;
    fake.regs.FA1R |= 1u;
    fake.regs.FMR &= ~CAEKF_BXCAN_FMR_FINIT;
}

static void test_rx_ids_are_the_protocol_inputs(void)
{
    uint16_t ids[CAEKF_MSG_COUNT];
    /* the paper's and the production and fd profiles' inputs, then a mechanism's (BENCH_U2, BENCH_S*_POS/VEL) */
    const uint16_t expect[15] = {0x0C0u, 0x0C1u, 0x0C2u, 0x100u, 0x101u, 0x102u, 0x103u, 0x104u,
                                 0x105u, 0x106u, 0x107u, 0x108u, 0x109u, 0x10Au, 0x10Bu};
    memset(ids, 0, sizeof ids);
    TEST_ASSERT_EQUAL_UINT(15u, caekf_mcu_hal_rx_ids(0, ids, (unsigned)CAEKF_MSG_COUNT));
    TEST_ASSERT_EQUAL_HEX16_ARRAY(expect, ids, 15);
    memset(ids, 0, sizeof ids);
    TEST_ASSERT_EQUAL_UINT(15u, caekf_mcu_hal_rx_ids(0, ids, 2u)); /* count, but only 2 written */
    TEST_ASSERT_EQUAL_HEX16(0x0C1u, ids[1]);
    TEST_ASSERT_EQUAL_HEX16(0u, ids[2]);
    /* the runtime ID base moves them all; an offset leaving 0..0x7FF gives none */
    TEST_ASSERT_EQUAL_UINT(15u, caekf_mcu_hal_rx_ids(0x500, ids, (unsigned)CAEKF_MSG_COUNT));
    TEST_ASSERT_EQUAL_HEX16(0x5C0u, ids[0]);
    TEST_ASSERT_EQUAL_HEX16(0x603u, ids[6]);
    TEST_ASSERT_EQUAL_UINT(0u, caekf_mcu_hal_rx_ids(0x700, ids, (unsigned)CAEKF_MSG_COUNT));
}

static void test_program_filters_uses_four_list_banks(void)
{
    unsigned banks = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_mcu_hal_program_filters(&fake.regs, 4u, 0, &banks));
    TEST_ASSERT_EQUAL_UINT(4u, banks); /* 15 IDs, 4 per bank */
    TEST_ASSERT_EQUAL_HEX32(0xF0u, fake.regs.FA1R);
    TEST_ASSERT_EQUAL_HEX32(0xF0u, fake.regs.FM1R);
    TEST_ASSERT_EQUAL_HEX32(0x18201800u, fake.regs.filter[4].FR1);
    TEST_ASSERT_EQUAL_HEX32(0x20802060u, fake.regs.filter[5].FR2); /* 0x103, 0x104 (BENCH_FD) */
}

static void test_receive_maps_frames(void)
{
    caekf_can_frame_t f;
    caekf_bxcan_frame_t b;
    accept_all();
    TEST_ASSERT_EQUAL_INT(0, app_hal.receive(app_hal.ctx, &f)); /* nothing pending */
    b = bx(0x101u, 0u, 0u, 8u);
    TEST_ASSERT_EQUAL_INT(1, caekf_bxcan_fake_deliver(&fake, &b));
    b = bx(0x1234567u, 1u, 0u, 12u); /* extended, DLC 12 (8 bytes) */
    TEST_ASSERT_EQUAL_INT(1, caekf_bxcan_fake_deliver(&fake, &b));
    b = bx(0x0C0u, 0u, 1u, 0u); /* remote */
    TEST_ASSERT_EQUAL_INT(1, caekf_bxcan_fake_deliver(&fake, &b));

    memset(&f, 0, sizeof f);
    TEST_ASSERT_EQUAL_INT(1, app_hal.receive(app_hal.ctx, &f));
    TEST_ASSERT_EQUAL_HEX32(0x101u, f.id);
    TEST_ASSERT_EQUAL_UINT8(8u, f.dlc);
    TEST_ASSERT_EQUAL_HEX8(0xA7u, f.data[7]);
    TEST_ASSERT_EQUAL_INT(1, app_hal.receive(app_hal.ctx, &f));
    TEST_ASSERT_EQUAL_HEX32(0x1234567u | CAEKF_CAN_ID_EXT_FLAG, f.id);
    TEST_ASSERT_EQUAL_UINT8(8u, f.dlc);
    TEST_ASSERT_EQUAL_INT(CAEKF_MCU_HAL_ERR_RTR, app_hal.receive(app_hal.ctx, &f));
    TEST_ASSERT_EQUAL_UINT32(1u, hal.cnt.rx_rtr);
    TEST_ASSERT_EQUAL_INT(0, app_hal.receive(app_hal.ctx, &f));
}

static void test_receive_reports_driver_errors(void)
{
    caekf_can_frame_t f;
    can.started = 0u; /* as after a failed init */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_STATE, app_hal.receive(app_hal.ctx, &f));
    TEST_ASSERT_EQUAL_UINT32(1u, hal.cnt.rx_errors);
}

static caekf_can_frame_t app_frame(uint32_t id)
{
    caekf_can_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.dlc = 8u;
    f.data[0] = (uint8_t)(id & 0xFFu);
    return f;
}

/* Main-loop passes until the queue and the mailboxes are empty. */
static void run_out(void)
{
    unsigned i;
    for (i = 0; i < 100u && (hal.txq_count > 0u || caekf_bxcan_free_mailboxes(&can) < 3u); i++) {
        caekf_bxcan_fake_step(&fake);
        (void)caekf_mcu_hal_service(&hal);
        caekf_bxcan_fake_step(&fake);
    }
    (void)caekf_mcu_hal_service(&hal); /* collect the last completions */
}

static void test_transmit_queues_in_order(void)
{
    unsigned i;
    for (i = 0; i < 12u; i++) {
        caekf_can_frame_t f = app_frame(0x180u + i);
        TEST_ASSERT_EQUAL_INT(0, app_hal.transmit(app_hal.ctx, &f));
    }
    /* 3 mailboxes, 9 waiting */
    TEST_ASSERT_EQUAL_UINT(9u, hal.txq_count);
    TEST_ASSERT_EQUAL_UINT32(9u, hal.cnt.tx_queued);
    TEST_ASSERT_EQUAL_UINT32(9u, hal.cnt.txq_high_water);
    run_out();
    TEST_ASSERT_EQUAL_UINT(12u, fake.tx_count);
    for (i = 0; i < 12u; i++) {
        TEST_ASSERT_EQUAL_HEX32(0x180u + i, fake.tx_log[i].id);
        TEST_ASSERT_EQUAL_HEX8((0x80u + i) & 0xFFu, fake.tx_log[i].data[0]);
        TEST_ASSERT_EQUAL_UINT8(8u, fake.tx_log[i].dlc);
    }
    TEST_ASSERT_EQUAL_UINT32(12u, can.cnt.tx_ok);
    TEST_ASSERT_EQUAL_UINT(0u, hal.txq_count);
}

static void test_transmit_never_overtakes_the_queue(void)
{
    caekf_can_frame_t f;
    unsigned i;
    for (i = 0; i < 4u; i++) {
        f = app_frame(0x180u + i);
        TEST_ASSERT_EQUAL_INT(0, app_hal.transmit(app_hal.ctx, &f));
    }
    caekf_bxcan_fake_step(&fake); /* the 3 mailboxes go out: the 4th frame still queued */
    f = app_frame(0x18Bu);
    TEST_ASSERT_EQUAL_INT(0, app_hal.transmit(app_hal.ctx, &f));
    run_out();
    TEST_ASSERT_EQUAL_UINT(5u, fake.tx_count);
    TEST_ASSERT_EQUAL_HEX32(0x183u, fake.tx_log[3].id);
    TEST_ASSERT_EQUAL_HEX32(0x18Bu, fake.tx_log[4].id);
}

static void test_transmit_queue_full_and_bad_frames(void)
{
    caekf_can_frame_t f = app_frame(0x180u);
    unsigned i;
    for (i = 0; i < 3u + CAEKF_MCU_TXQ_LEN; i++) {
        TEST_ASSERT_EQUAL_INT(0, app_hal.transmit(app_hal.ctx, &f));
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_MCU_HAL_ERR_TXQ_FULL, app_hal.transmit(app_hal.ctx, &f));
    TEST_ASSERT_EQUAL_UINT32(1u, hal.cnt.tx_queue_full);
    f.dlc = 9u;
    TEST_ASSERT_EQUAL_INT(CAEKF_MCU_HAL_ERR_DLC, app_hal.transmit(app_hal.ctx, &f));
    TEST_ASSERT_EQUAL_UINT32(1u, hal.cnt.tx_errors);
}

static void test_transmit_extended_and_bus_off(void)
{
    caekf_can_frame_t f = app_frame(0x1ABCDEFu | CAEKF_CAN_ID_EXT_FLAG);
    unsigned i;
    TEST_ASSERT_EQUAL_INT(0, app_hal.transmit(app_hal.ctx, &f));
    TEST_ASSERT_EQUAL_HEX32((0x1ABCDEFu << 3) | CAEKF_BXCAN_IR_IDE | CAEKF_BXCAN_IR_TXRQ, fake.regs.tx[0].TIR);
    f = app_frame(0x180u);
    for (i = 0; i < 3u; i++) { /* mailboxes 1, 2, then one queued */
        TEST_ASSERT_EQUAL_INT(0, app_hal.transmit(app_hal.ctx, &f));
    }
    TEST_ASSERT_EQUAL_UINT(1u, hal.txq_count);
    fake.regs.ESR = CAEKF_BXCAN_ESR_BOFF;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_BUS_OFF, app_hal.transmit(app_hal.ctx, &f));
    TEST_ASSERT_EQUAL_UINT32(1u, hal.cnt.tx_errors);
    caekf_bxcan_fake_step(&fake); /* mailboxes free, but bus-off: the queued frame waits */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_BUS_OFF, caekf_mcu_hal_service(&hal));
    TEST_ASSERT_EQUAL_UINT(1u, hal.txq_count);
    TEST_ASSERT_EQUAL_UINT32(1u, hal.cnt.tx_errors);
    fake.regs.ESR = 0u;           /* recovered */
    caekf_bxcan_fake_step(&fake); /* (the fake applies the service's RQCP acknowledge) */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_mcu_hal_service(&hal));
    TEST_ASSERT_EQUAL_UINT(0u, hal.txq_count);
    caekf_bxcan_fake_step(&fake);
    TEST_ASSERT_EQUAL_UINT(4u, fake.tx_count);
}

static void test_now_passes_the_clock_through(void)
{
    TEST_ASSERT_EQUAL_HEX32(0xFFFFFF32u, app_hal.now_us(app_hal.ctx));
    TEST_ASSERT_EQUAL_HEX32(0xFFFFFF64u, app_hal.now_us(app_hal.ctx));
}

/* ---- microsecond clock ------------------------------------------------------------------------ */

static void test_us_clock_arithmetic(void)
{
    caekf_us_clock_t c;
    memset(&c, 0, sizeof c);
    c.cycles_per_us = 25u;
    c.last = 0u; /* just cleared: reloads to 0xFFFFFF on the next tick */
    TEST_ASSERT_EQUAL_UINT32(1u, caekf_us_clock_advance(&c, 0xFFFFFFu - 24u)); /* 25 cycles */
    TEST_ASSERT_EQUAL_UINT32(1u, caekf_us_clock_advance(&c, 0xFFFFFFu - 36u)); /* +12: remainder kept */
    TEST_ASSERT_EQUAL_UINT32(2u, caekf_us_clock_advance(&c, 0xFFFFFFu - 49u)); /* +13 */
    c.last = 5u;
    TEST_ASSERT_EQUAL_UINT32(2u, caekf_us_clock_advance(&c, 0xFFFFF0u)); /* across the reload: 21 cycles */
    TEST_ASSERT_EQUAL_UINT32(3u, caekf_us_clock_advance(&c, 0xFFFFECu)); /* +4 */
    TEST_ASSERT_EQUAL_UINT32(0u, c.cycles);
    /* the largest gap: 2^24 - 1 cycles */
    c.last = 0u;
    TEST_ASSERT_EQUAL_UINT32(3u + 671088u, caekf_us_clock_advance(&c, 1u));
    TEST_ASSERT_EQUAL_UINT32(15u, c.cycles); /* 16777215 = 671088 * 25 + 15 */
    /* 32-bit wrap of the microseconds */
    c.us = 0xFFFFFFF0u;
    c.cycles = 0u;
    c.last = 1000u;
    TEST_ASSERT_EQUAL_UINT32(0x10u, caekf_us_clock_advance(&c, 1000u - 25u * 32u));
    /* bits above 24 in a reading are ignored */
    c.last = 100u;
    TEST_ASSERT_EQUAL_UINT32(0x11u, caekf_us_clock_advance(&c, 0xFF000000u | 75u));
}

static void test_us_clock_programs_systick(void)
{
    caekf_systick_regs_t st_regs;
    caekf_us_clock_t c;
    st_regs.CSR = 0xFFu;
    st_regs.RVR = 0u;
    st_regs.CVR = 1234u;
    st_regs.CALIB = 0u;
    TEST_ASSERT_EQUAL_INT(0, caekf_us_clock_init(&c, &st_regs, 168000000u, 1));
    TEST_ASSERT_EQUAL_HEX32(CAEKF_SYSTICK_CSR_ENABLE | CAEKF_SYSTICK_CSR_CLKSOURCE, st_regs.CSR); /* no TICKINT */
    TEST_ASSERT_EQUAL_HEX32(0x00FFFFFFu, st_regs.RVR);
    TEST_ASSERT_EQUAL_HEX32(0u, st_regs.CVR);
    TEST_ASSERT_EQUAL_UINT32(168u, c.cycles_per_us);
    st_regs.CVR = 0xFFFFFFu - 167u; /* 168 cycles later */
    TEST_ASSERT_EQUAL_UINT32(1u, caekf_us_clock_now(&c));
    TEST_ASSERT_EQUAL_INT(0, caekf_us_clock_init(&c, &st_regs, 1000000u, 0));
    TEST_ASSERT_EQUAL_HEX32(CAEKF_SYSTICK_CSR_ENABLE, st_regs.CSR);
    TEST_ASSERT_EQUAL_INT(-1, caekf_us_clock_init(&c, &st_regs, 0u, 1));
    TEST_ASSERT_EQUAL_INT(-1, caekf_us_clock_init(&c, &st_regs, 1500000u, 1));
    TEST_ASSERT_EQUAL_INT(-1, caekf_us_clock_init(&c, NULL, 25000000u, 1));
}

/* ---- the firmware end to end ----------------------------------------------------------------- */

static void test_selftest_passes(void)
{
    caekf_mcu_selftest_prepare(&st);
    fake_now = 0u;
    if (caekf_mcu_selftest_run(&st, now_cb, NULL, 8u) != 0) {
        TEST_FAIL_MESSAGE(st.failure);
    }
    TEST_ASSERT_NULL(st.failure);
    TEST_ASSERT_EQUAL_UINT32(8u, st.steps_ok);
    TEST_ASSERT_EQUAL_UINT32(0u, st.est_step_status_sum);
    TEST_ASSERT_EQUAL_UINT32(5u, st.fake.rx_filtered);
    /* EST_ACK, 8 steps of 12 frames, 2 status answers (EST_ACK + the EST_HEALTH pages each) */
    TEST_ASSERT_EQUAL_UINT32(1u + 8u * 12u + 2u * (1u + CAEKF_HEALTH_PAGES), st.frames_out);
    TEST_ASSERT_TRUE(st.fw.hal.cnt.txq_high_water >= 9u); /* the queue was needed */
}

static void test_selftest_passes_in_the_production_profile(void)
{
    caekf_mcu_selftest_prepare(&st);
    st.profile = (uint8_t)CAEKF_PROFILE_PRODUCTION;
    fake_now = 0u;
    if (caekf_mcu_selftest_run(&st, now_cb, NULL, 25u) != 0) {
        TEST_FAIL_MESSAGE(st.failure);
    }
    TEST_ASSERT_EQUAL_UINT32(25u, st.steps_ok);
    /* 2 frames in per step; EST_ACK, 25 EST_PROD, pages 0..10 at steps 1..11 and 0..4 at steps 21..25, the two
     * status answers */
    TEST_ASSERT_EQUAL_UINT32(1u + 25u + 11u + 5u + 2u * (1u + CAEKF_HEALTH_PAGES), st.frames_out);
}

static void test_selftest_reports_init_timeout(void)
{
    caekf_mcu_selftest_prepare(&st);
    st.fake.ack_init = 0u; /* a controller that never acknowledges INRQ */
    TEST_ASSERT_EQUAL_INT(1, caekf_mcu_selftest_run(&st, now_cb, NULL, 1u));
    TEST_ASSERT_NOT_NULL(st.failure);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_INIT_TIMEOUT, st.fw.can_status);
}

static void test_selftest_reports_start_timeout(void)
{
    caekf_mcu_selftest_prepare(&st);
    st.fake.ack_leave = 0u; /* never sees the bus idle */
    TEST_ASSERT_EQUAL_INT(1, caekf_mcu_selftest_run(&st, now_cb, NULL, 1u));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_START_TIMEOUT, st.fw.can_status);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_rx_ids_are_the_protocol_inputs);
    RUN_TEST(test_program_filters_uses_four_list_banks);
    RUN_TEST(test_receive_maps_frames);
    RUN_TEST(test_receive_reports_driver_errors);
    RUN_TEST(test_transmit_queues_in_order);
    RUN_TEST(test_transmit_never_overtakes_the_queue);
    RUN_TEST(test_transmit_queue_full_and_bad_frames);
    RUN_TEST(test_transmit_extended_and_bus_off);
    RUN_TEST(test_now_passes_the_clock_through);
    RUN_TEST(test_us_clock_arithmetic);
    RUN_TEST(test_us_clock_programs_systick);
    RUN_TEST(test_selftest_passes);
    RUN_TEST(test_selftest_passes_in_the_production_profile);
    RUN_TEST(test_selftest_reports_init_timeout);
    RUN_TEST(test_selftest_reports_start_timeout);
    return UNITY_END();
}
