/*
 * Unity tests of the bxCAN driver (firmware/port/cortex-m/can/bxcan.c) against a register block in
 * RAM. RAM does not react: where the hardware would (INAK after INRQ, TXRQ -> sent, RFOM -> next
 * message) the test either pre-sets the bits, or passes a small hook that plays the controller, or
 * uses the simulated controller of bxcan_fake.c. Register contents are checked bit for bit.
 */
#include <stddef.h>
#include <string.h>

#include "bxcan.h"
#include "bxcan_fake.h"
#include "unity.h"

static caekf_bxcan_regs_t regs;
static caekf_bxcan_t can;
static caekf_bxcan_fake_t fake;

/* hook log */
static unsigned hook_calls;
static uint32_t hook_mcr[8], hook_btr[8];

#define BTR_RESET 0x01230000u

static void regs_reset(caekf_bxcan_regs_t *r)
{
    volatile uint32_t *w = &r->MCR;
    size_t i;
    for (i = 0; i < sizeof *r / sizeof(uint32_t); i++) {
        w[i] = 0u;
    }
    r->MCR = CAEKF_BXCAN_MCR_RESET_VALUE;
    r->MSR = CAEKF_BXCAN_MSR_RESET_VALUE;
    r->TSR = CAEKF_BXCAN_TSR_RESET_VALUE;
    r->BTR = BTR_RESET;
    r->FMR = CAEKF_BXCAN_FMR_RESET_VALUE;
}

void setUp(void)
{
    regs_reset(&regs);
    memset(&can, 0, sizeof can);
    caekf_bxcan_fake_reset(&fake);
    hook_calls = 0;
}

void tearDown(void) {}

/* Plays the controller's acknowledge: INAK follows INRQ, SLAK follows SLEEP outside init. Logs. */
static void ack_hook(void *ctx)
{
    caekf_bxcan_regs_t *r = (caekf_bxcan_regs_t *)ctx;
    uint32_t mcr = r->MCR, msr = r->MSR & ~(CAEKF_BXCAN_MSR_INAK | CAEKF_BXCAN_MSR_SLAK);
    if (hook_calls < 8u) {
        hook_mcr[hook_calls] = mcr;
        hook_btr[hook_calls] = r->BTR;
    }
    hook_calls++;
    if (mcr & CAEKF_BXCAN_MCR_INRQ) {
        msr |= CAEKF_BXCAN_MSR_INAK;
    } else if (mcr & CAEKF_BXCAN_MCR_SLEEP) {
        msr |= CAEKF_BXCAN_MSR_SLAK;
    }
    r->MSR = msr;
}

static void count_hook(void *ctx)
{
    (void)ctx;
    hook_calls++;
}

static void config_500k(caekf_bxcan_config_t *cfg)
{
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_config_default(cfg));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_timing_compute(42000000u, 500000u, 875u, &cfg->timing));
}

/* Driver started on `regs` (hook plays the acknowledge), hook log cleared. */
static void start(void)
{
    caekf_bxcan_config_t cfg;
    config_500k(&cfg);
    cfg.wait_limit = 10u;
    cfg.wait_hook = ack_hook;
    cfg.wait_ctx = &regs;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_init(&can, &regs, &cfg));
    hook_calls = 0;
}

/* Driver started on the fake controller, with the fake as wait hook. */
static void start_fake(void)
{
    caekf_bxcan_config_t cfg;
    config_500k(&cfg);
    cfg.wait_limit = 10u;
    cfg.wait_hook = caekf_bxcan_fake_hook;
    cfg.wait_ctx = &fake;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_init(&can, &fake.regs, &cfg));
}

/* ---- layout and timing ---------------------------------------------------------------------- */

static void test_register_layout(void)
{
    const char *base = (const char *)&regs;
    TEST_ASSERT_EQUAL_UINT(0x320u, sizeof regs);
    TEST_ASSERT_EQUAL_UINT(0x018u, (unsigned)((const char *)&regs.ESR - base));
    TEST_ASSERT_EQUAL_UINT(0x1A4u, (unsigned)((const char *)&regs.tx[2].TDTR - base));
    TEST_ASSERT_EQUAL_UINT(0x1C8u, (unsigned)((const char *)&regs.rx[1].RDLR - base));
    TEST_ASSERT_EQUAL_UINT(0x21Cu, (unsigned)((const char *)&regs.FA1R - base));
    TEST_ASSERT_EQUAL_UINT(0x2B0u, (unsigned)((const char *)&regs.filter[14].FR1 - base));
}

static void expect_timing(uint32_t pclk, uint32_t rate, unsigned presc, unsigned ts1, unsigned ts2, uint32_t btr)
{
    caekf_bxcan_timing_t t;
    uint32_t v = 0;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_timing_compute(pclk, rate, 875u, &t));
    TEST_ASSERT_EQUAL_UINT(presc, t.prescaler);
    TEST_ASSERT_EQUAL_UINT(ts1, t.ts1);
    TEST_ASSERT_EQUAL_UINT(ts2, t.ts2);
    TEST_ASSERT_EQUAL_UINT(1u, t.sjw);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_timing_btr(&t, &v));
    TEST_ASSERT_EQUAL_HEX32(btr, v);
}

static void test_timing_common_rates(void)
{
    expect_timing(42000000u, 500000u, 6u, 11u, 2u, 0x001A0005u);  /* F4 at 168 MHz: 14 tq, 85.7 % */
    expect_timing(42000000u, 1000000u, 3u, 11u, 2u, 0x001A0002u); /* F4, 1 Mbit/s */
    expect_timing(54000000u, 500000u, 6u, 15u, 2u, 0x001E0005u);  /* F7 at 216 MHz: 18 tq, 88.9 % */
    expect_timing(54000000u, 1000000u, 3u, 15u, 2u, 0x001E0002u); /* F7, 1 Mbit/s (caekf_fw on an F7) */
    expect_timing(16000000u, 500000u, 2u, 13u, 2u, 0x001C0001u);  /* HSI reset clock: 16 tq, 87.5 % */
    expect_timing(16000000u, 1000000u, 1u, 13u, 2u, 0x001C0000u);
    expect_timing(9500000u, 500000u, 1u, 16u, 2u, 0x001F0000u); /* 19 tq: the largest TS1 */
}

static void test_timing_refusals(void)
{
    caekf_bxcan_timing_t t = {1u, 1u, 1u, 1u};
    uint32_t v = 0xDEADBEEFu;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_timing_compute(42000000u, 333333u, 875u, &t));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_timing_compute(42000000u, 0u, 875u, &t));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_timing_compute(42000000u, 500000u, 400u, &t));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_NULL, caekf_bxcan_timing_compute(42000000u, 500000u, 875u, NULL));
    t.prescaler = 0u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_timing_btr(&t, &v));
    t.prescaler = 1025u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_timing_btr(&t, &v));
    t.prescaler = 1024u;
    t.ts1 = 17u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_timing_btr(&t, &v));
    t.ts1 = 16u;
    t.ts2 = 9u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_timing_btr(&t, &v));
    t.ts2 = 2u;
    t.sjw = 3u; /* more than ts2 */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_timing_btr(&t, &v));
    TEST_ASSERT_EQUAL_HEX32(0xDEADBEEFu, v);
    t.sjw = 2u; /* the largest fields */
    t.ts2 = 8u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_timing_btr(&t, &v));
    TEST_ASSERT_EQUAL_HEX32(0x017F03FFu, v);
}

/* ---- init ------------------------------------------------------------------------------------- */

static void test_init_sequence(void)
{
    caekf_bxcan_config_t cfg;
    config_500k(&cfg);
    cfg.wait_limit = 10u;
    cfg.wait_hook = ack_hook;
    cfg.wait_ctx = &regs;
    regs.IER = 0xFFFFu;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_init(&can, &regs, &cfg));
    /* one hook call per wait: entering (INRQ set, SLEEP cleared, BTR not yet written) ... */
    TEST_ASSERT_EQUAL_UINT(2u, hook_calls);
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_MCR_DBF | CAEKF_BXCAN_MCR_INRQ, hook_mcr[0]);
    TEST_ASSERT_EQUAL_HEX32(BTR_RESET, hook_btr[0]);
    /* ... and leaving (INRQ cleared, options and BTR in place) */
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_MCR_DBF | CAEKF_BXCAN_MCR_TXFP | CAEKF_BXCAN_MCR_ABOM, hook_mcr[1]);
    TEST_ASSERT_EQUAL_HEX32(0x001A0005u, hook_btr[1]);
    TEST_ASSERT_EQUAL_HEX32(0x00010044u, regs.MCR);
    TEST_ASSERT_EQUAL_HEX32(0x001A0005u, regs.BTR);
    TEST_ASSERT_EQUAL_HEX32(0u, regs.IER);
    TEST_ASSERT_EQUAL_UINT8(1u, can.started);
}

static void test_init_options_and_modes(void)
{
    caekf_bxcan_config_t cfg;
    config_500k(&cfg);
    cfg.wait_hook = ack_hook;
    cfg.wait_ctx = &regs;
    cfg.tx_fifo_order = 0u;
    cfg.auto_bus_off_recovery = 0u;
    cfg.no_auto_retransmit = 1u;
    cfg.rx_fifo_locked = 1u;
    cfg.loopback = 1u;
    cfg.silent = 1u;
    regs.MCR = 0u; /* DBF clear stays clear */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_init(&can, &regs, &cfg));
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_MCR_NART | CAEKF_BXCAN_MCR_RFLM, regs.MCR);
    TEST_ASSERT_EQUAL_HEX32(0xC01A0005u, regs.BTR);
}

static void test_init_never_acknowledged_times_out(void)
{
    caekf_bxcan_config_t cfg;
    config_500k(&cfg);
    cfg.wait_limit = 50u;
    cfg.wait_hook = count_hook; /* the controller never reacts */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_INIT_TIMEOUT, caekf_bxcan_init(&can, &regs, &cfg));
    TEST_ASSERT_EQUAL_UINT(50u, hook_calls); /* bounded: exactly wait_limit iterations */
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_MCR_DBF | CAEKF_BXCAN_MCR_INRQ, regs.MCR);
    TEST_ASSERT_EQUAL_HEX32(BTR_RESET, regs.BTR); /* nothing configured */
    TEST_ASSERT_EQUAL_UINT8(0u, can.started);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_STATE, caekf_bxcan_receive(&can, &(caekf_bxcan_frame_t){0}));
}

static void test_init_sleep_never_left_times_out(void)
{
    caekf_bxcan_config_t cfg;
    config_500k(&cfg);
    cfg.wait_limit = 5u;
    regs.MSR = CAEKF_BXCAN_MSR_INAK | CAEKF_BXCAN_MSR_SLAK; /* INAK given, but still asleep */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_INIT_TIMEOUT, caekf_bxcan_init(&can, &regs, &cfg));
}

static void test_init_preset_ack_then_start_timeout(void)
{
    /* The test pre-sets INAK: entering passes without a hook; leaving needs INAK to clear, which a
     * passive RAM block never does (as a controller that never sees 11 recessive bits). */
    caekf_bxcan_config_t cfg;
    config_500k(&cfg);
    cfg.wait_limit = 20u;
    regs.MSR = CAEKF_BXCAN_MSR_INAK;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_START_TIMEOUT, caekf_bxcan_init(&can, &regs, &cfg));
    TEST_ASSERT_EQUAL_HEX32(0x001A0005u, regs.BTR); /* configured ... */
    TEST_ASSERT_EQUAL_HEX32(0x00010044u, regs.MCR); /* ... and INRQ cleared */
    TEST_ASSERT_EQUAL_UINT8(0u, can.started);
}

static void test_init_refuses_bad_timing_untouched(void)
{
    caekf_bxcan_config_t cfg;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_config_default(&cfg)); /* timing all zero */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_init(&can, &regs, &cfg));
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_MCR_RESET_VALUE, regs.MCR);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_NULL, caekf_bxcan_init(&can, NULL, &cfg));
}

/* ---- filters ---------------------------------------------------------------------------------- */

static const uint16_t proto_ids[6] = {0x0C0u, 0x0C1u, 0x0C2u, 0x100u, 0x101u, 0x102u};

static void test_filter_list16_bits(void)
{
    unsigned banks = 0;
    regs.FM1R = 1u << 5; /* bank 5: someone else's 32-bit mask filter, must stay */
    regs.FS1R = (1u << 5) | 3u;
    regs.FFA1R = 3u;
    regs.FA1R = 1u << 5;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_filter_list16(&regs, 0u, proto_ids, 6u, 0u, &banks));
    TEST_ASSERT_EQUAL_UINT(2u, banks);
    TEST_ASSERT_EQUAL_HEX32(0x18201800u, regs.filter[0].FR1); /* 0x0C1 << 5 : 0x0C0 << 5 */
    TEST_ASSERT_EQUAL_HEX32(0x20001840u, regs.filter[0].FR2); /* 0x100 : 0x0C2 */
    TEST_ASSERT_EQUAL_HEX32(0x20402020u, regs.filter[1].FR1); /* 0x102 : 0x101 */
    TEST_ASSERT_EQUAL_HEX32(0x20402040u, regs.filter[1].FR2); /* padded with the last ID */
    TEST_ASSERT_EQUAL_HEX32((1u << 5) | 3u, regs.FM1R);       /* list mode */
    TEST_ASSERT_EQUAL_HEX32(1u << 5, regs.FS1R);              /* 16-bit scale */
    TEST_ASSERT_EQUAL_HEX32(0u, regs.FFA1R);                  /* FIFO 0 */
    TEST_ASSERT_EQUAL_HEX32((1u << 5) | 3u, regs.FA1R);       /* active */
    TEST_ASSERT_EQUAL_HEX32(0x2A1C0E00u, regs.FMR);           /* FINIT cleared, CAN2SB kept */
    TEST_ASSERT_EQUAL_HEX32(0u, regs.filter[2].FR1);
}

static void test_filter_list16_bank_and_fifo1(void)
{
    const uint16_t one = 0x7FFu;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_filter_list16(&regs, 27u, &one, 1u, 1u, NULL));
    TEST_ASSERT_EQUAL_HEX32(0xFFE0FFE0u, regs.filter[27].FR1);
    TEST_ASSERT_EQUAL_HEX32(0xFFE0FFE0u, regs.filter[27].FR2);
    TEST_ASSERT_EQUAL_HEX32(1u << 27, regs.FFA1R);
    TEST_ASSERT_EQUAL_HEX32(1u << 27, regs.FM1R);
    TEST_ASSERT_EQUAL_HEX32(1u << 27, regs.FA1R);
}

static void test_filter_refusals_leave_registers(void)
{
    const uint16_t bad[2] = {0x100u, 0x800u};
    const uint16_t id[2] = {0x100u, 0x0C0u}, mask_bad[2] = {0x7FFu, 0xFFFFu};
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_filter_list16(&regs, 0u, bad, 2u, 0u, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_filter_list16(&regs, 0u, proto_ids, 0u, 0u, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_filter_list16(&regs, 27u, proto_ids, 5u, 0u, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_filter_list16(&regs, 0u, proto_ids, 6u, 2u, NULL));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_filter_mask16(&regs, 0u, id, mask_bad, 0u));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_filter_mask16(&regs, 28u, id, id, 0u));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_NULL, caekf_bxcan_filter_list16(&regs, 0u, NULL, 1u, 0u, NULL));
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_FMR_RESET_VALUE, regs.FMR);
    TEST_ASSERT_EQUAL_HEX32(0u, regs.FA1R | regs.FM1R | regs.FS1R | regs.FFA1R);
    TEST_ASSERT_EQUAL_HEX32(0u, regs.filter[0].FR1 | regs.filter[0].FR2);
}

static void test_filter_mask16_bits(void)
{
    const uint16_t id[2] = {0x100u, 0x0C0u}, mask[2] = {0x7FCu, 0x7FFu};
    regs.FM1R = 1u << 2; /* was a list: becomes a mask */
    regs.FFA1R = 1u << 2;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_filter_mask16(&regs, 2u, id, mask, 0u));
    /* identifier in 15:0, mask in 31:16 with RTR and IDE bits set (must be 0) */
    TEST_ASSERT_EQUAL_HEX32(0xFF982000u, regs.filter[2].FR1);
    TEST_ASSERT_EQUAL_HEX32(0xFFF81800u, regs.filter[2].FR2);
    TEST_ASSERT_EQUAL_HEX32(0u, regs.FM1R);
    TEST_ASSERT_EQUAL_HEX32(0u, regs.FS1R);
    TEST_ASSERT_EQUAL_HEX32(0u, regs.FFA1R);
    TEST_ASSERT_EQUAL_HEX32(1u << 2, regs.FA1R);
    TEST_ASSERT_EQUAL_HEX32(0x2A1C0E00u, regs.FMR);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_filter_deactivate(&regs, 2u, 1u));
    TEST_ASSERT_EQUAL_HEX32(0u, regs.FA1R);
}

static caekf_bxcan_frame_t frame(uint32_t id, uint8_t ide, uint8_t rtr)
{
    caekf_bxcan_frame_t f;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.ide = ide;
    f.rtr = rtr;
    f.dlc = 8u;
    return f;
}

static void test_filters_accept_what_they_should(void)
{
    /* The programmed bits, read back as the reference manual's acceptance rules (the fake's). */
    const uint16_t id[2] = {0x100u, 0x0C0u}, mask[2] = {0x7FCu, 0x7FFu};
    unsigned i, fifo = 9, fmi = 99;
    caekf_bxcan_frame_t f;
    fake.regs.FMR &= ~CAEKF_BXCAN_FMR_FINIT;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_filter_list16(&fake.regs, 0u, proto_ids, 6u, 0u, NULL));
    for (i = 0; i < 6u; i++) {
        f = frame(proto_ids[i], 0u, 0u);
        TEST_ASSERT_EQUAL_INT(1, caekf_bxcan_fake_match(&fake, &f, &fifo, &fmi));
        TEST_ASSERT_EQUAL_UINT(0u, fifo);
        TEST_ASSERT_EQUAL_UINT(i, fmi);
    }
    f = frame(0x0C3u, 0u, 0u);
    TEST_ASSERT_EQUAL_INT(0, caekf_bxcan_fake_match(&fake, &f, NULL, NULL));
    f = frame(0x180u, 0u, 0u);
    TEST_ASSERT_EQUAL_INT(0, caekf_bxcan_fake_match(&fake, &f, NULL, NULL));
    f = frame(0x0C0u, 1u, 0u); /* extended 0x0C0 */
    TEST_ASSERT_EQUAL_INT(0, caekf_bxcan_fake_match(&fake, &f, NULL, NULL));
    f = frame(0x0C0u << 18, 1u, 0u); /* extended with the same 11 upper bits */
    TEST_ASSERT_EQUAL_INT(0, caekf_bxcan_fake_match(&fake, &f, NULL, NULL));
    f = frame(0x100u, 0u, 1u); /* remote */
    TEST_ASSERT_EQUAL_INT(0, caekf_bxcan_fake_match(&fake, &f, NULL, NULL));

    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_filter_deactivate(&fake.regs, 0u, 2u));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_filter_mask16(&fake.regs, 2u, id, mask, 0u));
    for (i = 0x100u; i <= 0x103u; i++) {
        f = frame(i, 0u, 0u);
        TEST_ASSERT_EQUAL_INT(1, caekf_bxcan_fake_match(&fake, &f, &fifo, &fmi));
        TEST_ASSERT_EQUAL_UINT(8u, fmi); /* banks 0, 1 (4 each, inactive but numbered), then bank 2 */
    }
    f = frame(0x104u, 0u, 0u);
    TEST_ASSERT_EQUAL_INT(0, caekf_bxcan_fake_match(&fake, &f, NULL, NULL));
    f = frame(0x0C0u, 0u, 0u);
    TEST_ASSERT_EQUAL_INT(1, caekf_bxcan_fake_match(&fake, &f, &fifo, &fmi));
    TEST_ASSERT_EQUAL_UINT(9u, fmi);
    f = frame(0x0C1u, 0u, 0u);
    TEST_ASSERT_EQUAL_INT(0, caekf_bxcan_fake_match(&fake, &f, NULL, NULL));
}

/* ---- transmit --------------------------------------------------------------------------------- */

static void test_transmit_fills_lowest_free_mailbox(void)
{
    caekf_bxcan_frame_t f = frame(0x18Bu, 0u, 0u);
    unsigned m = 99, i;
    for (i = 0; i < 8u; i++) {
        f.data[i] = (uint8_t)(i + 1u);
    }
    start();
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_transmit(&can, &f, &m));
    TEST_ASSERT_EQUAL_UINT(0u, m);
    TEST_ASSERT_EQUAL_HEX32((0x18Bu << 21) | CAEKF_BXCAN_IR_TXRQ, regs.tx[0].TIR);
    TEST_ASSERT_EQUAL_HEX32(8u, regs.tx[0].TDTR);
    TEST_ASSERT_EQUAL_HEX32(0x04030201u, regs.tx[0].TDLR);
    TEST_ASSERT_EQUAL_HEX32(0x08070605u, regs.tx[0].TDHR);
    /* TSR still says TME0 (RAM): the pending TXRQ keeps mailbox 0 taken */
    f.id = 0x180u;
    f.dlc = 3u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_transmit(&can, &f, &m));
    TEST_ASSERT_EQUAL_UINT(1u, m);
    TEST_ASSERT_EQUAL_HEX32((0x180u << 21) | CAEKF_BXCAN_IR_TXRQ, regs.tx[1].TIR);
    TEST_ASSERT_EQUAL_HEX32(3u, regs.tx[1].TDTR);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_transmit(&can, &f, &m));
    TEST_ASSERT_EQUAL_UINT(2u, m);
    TEST_ASSERT_EQUAL_UINT(0u, caekf_bxcan_free_mailboxes(&can));
    /* all three taken: BUSY, nothing written */
    f.id = 0x7FFu;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_BUSY, caekf_bxcan_transmit(&can, &f, &m));
    TEST_ASSERT_EQUAL_HEX32((0x180u << 21) | CAEKF_BXCAN_IR_TXRQ, regs.tx[2].TIR);
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.tx_busy);
    TEST_ASSERT_EQUAL_UINT32(3u, can.cnt.tx_requests);
}

static void test_transmit_follows_tme(void)
{
    caekf_bxcan_frame_t f = frame(0x123u, 0u, 0u);
    unsigned m = 99;
    start();
    regs.TSR = CAEKF_BXCAN_TSR_TME(2);
    TEST_ASSERT_EQUAL_UINT(1u, caekf_bxcan_free_mailboxes(&can));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_transmit(&can, &f, &m));
    TEST_ASSERT_EQUAL_UINT(2u, m);
    TEST_ASSERT_EQUAL_HEX32(0u, regs.tx[0].TIR | regs.tx[1].TIR);
    regs.TSR = 0u;
    regs.tx[2].TIR = 0u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_BUSY, caekf_bxcan_transmit(&can, &f, &m));
    TEST_ASSERT_EQUAL_HEX32(0u, regs.tx[0].TIR | regs.tx[1].TIR | regs.tx[2].TIR);
}

static void test_transmit_extended_and_remote(void)
{
    caekf_bxcan_frame_t f = frame(0x1ABCDEFu, 1u, 0u);
    start();
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_transmit(&can, &f, NULL));
    TEST_ASSERT_EQUAL_HEX32((0x1ABCDEFu << 3) | CAEKF_BXCAN_IR_IDE | CAEKF_BXCAN_IR_TXRQ, regs.tx[0].TIR);
    f = frame(0x0C2u, 0u, 1u);
    f.dlc = 0u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_transmit(&can, &f, NULL));
    TEST_ASSERT_EQUAL_HEX32((0x0C2u << 21) | CAEKF_BXCAN_IR_RTR | CAEKF_BXCAN_IR_TXRQ, regs.tx[1].TIR);
    TEST_ASSERT_EQUAL_HEX32(0u, regs.tx[1].TDTR);
}

static void test_transmit_refusals(void)
{
    caekf_bxcan_frame_t f = frame(0x100u, 0u, 0u);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_STATE, caekf_bxcan_transmit(&can, &f, NULL)); /* not started */
    start();
    f.dlc = 9u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_transmit(&can, &f, NULL));
    f = frame(0x800u, 0u, 0u);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_transmit(&can, &f, NULL));
    f = frame(0x20000000u, 1u, 0u);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_PARAM, caekf_bxcan_transmit(&can, &f, NULL));
    f = frame(0x100u, 0u, 0u);
    regs.ESR = CAEKF_BXCAN_ESR_BOFF;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_BUS_OFF, caekf_bxcan_transmit(&can, &f, NULL));
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.bus_off_refused);
    TEST_ASSERT_EQUAL_HEX32(0u, regs.tx[0].TIR | regs.tx[1].TIR | regs.tx[2].TIR);
    TEST_ASSERT_EQUAL_UINT32(0u, can.cnt.tx_requests);
}

/* ---- receive ---------------------------------------------------------------------------------- */

static void test_receive_decodes_and_releases(void)
{
    caekf_bxcan_frame_t f;
    unsigned i;
    start();
    regs.RF0R = 1u;
    regs.rx[0].RIR = 0x101u << 21;
    regs.rx[0].RDTR = 8u | (5u << 8) | (0x1234u << 16);
    regs.rx[0].RDLR = 0x44332211u;
    regs.rx[0].RDHR = 0x88776655u;
    memset(&f, 0xEE, sizeof f);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_receive(&can, &f));
    TEST_ASSERT_EQUAL_HEX32(0x101u, f.id);
    TEST_ASSERT_EQUAL_UINT8(0u, f.ide);
    TEST_ASSERT_EQUAL_UINT8(0u, f.rtr);
    TEST_ASSERT_EQUAL_UINT8(8u, f.dlc);
    TEST_ASSERT_EQUAL_UINT8(5u, f.fmi);
    TEST_ASSERT_EQUAL_HEX16(0x1234u, f.time);
    for (i = 0; i < 8u; i++) {
        TEST_ASSERT_EQUAL_HEX8((i + 1u) * 0x11u, f.data[i]);
    }
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_RFR_RFOM, regs.RF0R); /* released, nothing else written */
    /* the release has not completed (RAM keeps RFOM): no second read of the same mailbox */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_EMPTY, caekf_bxcan_receive(&can, &f));
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.rx_frames);
}

static void test_receive_waits_for_a_pending_release(void)
{
    /* RFOM still set: the output mailbox still shows the released message (FMP not yet decremented).
     * Without a hook nothing completes it: EMPTY, no read, no write. */
    caekf_bxcan_frame_t f;
    start();
    regs.RF0R = CAEKF_BXCAN_RFR_RFOM | 2u;
    regs.rx[0].RIR = 0x100u << 21;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_EMPTY, caekf_bxcan_receive(&can, &f));
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_RFR_RFOM | 2u, regs.RF0R);
    TEST_ASSERT_EQUAL_UINT32(0u, can.cnt.rx_frames);
}

static void test_receive_empty_writes_nothing(void)
{
    caekf_bxcan_frame_t f;
    start();
    regs.RF0R = 0u;
    regs.rx[0].RIR = 0x100u << 21;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_EMPTY, caekf_bxcan_receive(&can, &f));
    TEST_ASSERT_EQUAL_HEX32(0u, regs.RF0R);
    TEST_ASSERT_EQUAL_UINT32(0u, can.cnt.rx_frames);
}

static void test_receive_extended_remote_raw_dlc(void)
{
    caekf_bxcan_frame_t f;
    start();
    regs.RF0R = 2u;
    regs.rx[0].RIR = (0x1FFFFFFFu << 3) | CAEKF_BXCAN_IR_IDE | CAEKF_BXCAN_IR_RTR;
    regs.rx[0].RDTR = 0xFu;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_receive(&can, &f));
    TEST_ASSERT_EQUAL_HEX32(0x1FFFFFFFu, f.id);
    TEST_ASSERT_EQUAL_UINT8(1u, f.ide);
    TEST_ASSERT_EQUAL_UINT8(1u, f.rtr);
    TEST_ASSERT_EQUAL_UINT8(15u, f.dlc);
}

static void test_receive_counts_and_clears_overrun(void)
{
    caekf_bxcan_frame_t f;
    start();
    regs.RF0R = 3u | CAEKF_BXCAN_RFR_FULL | CAEKF_BXCAN_RFR_FOVR;
    regs.rx[0].RIR = 0x0C0u << 21;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_receive(&can, &f));
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.rx_overruns);
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.rx_full);
    /* one write: release and clear exactly the flags seen */
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_RFR_RFOM | CAEKF_BXCAN_RFR_FULL | CAEKF_BXCAN_RFR_FOVR, regs.RF0R);
}

static void expect_rx(uint32_t id)
{
    caekf_bxcan_frame_t f;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_receive(&can, &f));
    TEST_ASSERT_EQUAL_HEX32(id, f.id);
    TEST_ASSERT_EQUAL_UINT8(id & 0xFFu, f.data[0]);
}

static void overrun_with_fake(int locked, const uint32_t expect[3])
{
    caekf_bxcan_config_t cfg;
    caekf_bxcan_frame_t f;
    const uint16_t ids[5] = {0x0C0u, 0x0C1u, 0x0C2u, 0x100u, 0x101u};
    unsigned i;
    config_500k(&cfg);
    cfg.rx_fifo_locked = (uint8_t)locked;
    cfg.wait_hook = caekf_bxcan_fake_hook;
    cfg.wait_ctx = &fake;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_init(&can, &fake.regs, &cfg));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_filter_list16(&fake.regs, 0u, ids, 5u, 0u, NULL));
    for (i = 0; i < 5u; i++) {
        f = frame(ids[i], 0u, 0u);
        f.data[0] = (uint8_t)(ids[i] & 0xFFu);
        TEST_ASSERT_EQUAL_INT(i < 3u ? 1 : -1, caekf_bxcan_fake_deliver(&fake, &f));
    }
    TEST_ASSERT_EQUAL_UINT32(2u, fake.rx_lost);
    /* the driver drains the FIFO (the fake completes each release inside the driver's spin) */
    for (i = 0; i < 3u; i++) {
        expect_rx(expect[i]);
    }
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_EMPTY, caekf_bxcan_receive(&can, &f));
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.rx_overruns); /* flag seen once, cleared with the first release */
    caekf_bxcan_fake_step(&fake);
    TEST_ASSERT_EQUAL_HEX32(0u, fake.regs.RF0R); /* FIFO empty, FULL and FOVR cleared */
}

static void test_overrun_newest_wins(void)
{
    const uint32_t expect[3] = {0x0C0u, 0x0C1u, 0x101u};
    overrun_with_fake(0, expect);
}

static void test_overrun_locked_fifo_keeps_oldest(void)
{
    const uint32_t expect[3] = {0x0C0u, 0x0C1u, 0x0C2u};
    overrun_with_fake(1, expect);
}

/* ---- service ---------------------------------------------------------------------------------- */

static void test_service_counts_completions(void)
{
    start();
    regs.TSR = CAEKF_BXCAN_TSR_TME_ALL | CAEKF_BXCAN_TSR_RQCP(0) | CAEKF_BXCAN_TSR_TXOK(0) | CAEKF_BXCAN_TSR_RQCP(1) |
               CAEKF_BXCAN_TSR_TERR(1) | CAEKF_BXCAN_TSR_RQCP(2) | CAEKF_BXCAN_TSR_ALST(2);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_service(&can));
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.tx_ok);
    TEST_ASSERT_EQUAL_UINT32(2u, can.cnt.tx_failed);
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.tx_arb_lost);
    TEST_ASSERT_EQUAL_HEX32(0x00010101u, regs.TSR); /* rc_w1 of the three RQCP bits only */
    /* RQCP without TME: the mailbox was refilled, not a completion to count */
    regs.TSR = CAEKF_BXCAN_TSR_RQCP(0) | CAEKF_BXCAN_TSR_TXOK(0) | CAEKF_BXCAN_TSR_TME(1);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_service(&can));
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.tx_ok);
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_TSR_RQCP(0) | CAEKF_BXCAN_TSR_TXOK(0) | CAEKF_BXCAN_TSR_TME(1), regs.TSR);
}

static void test_refilled_mailbox_completion_counted_once(void)
{
    caekf_bxcan_frame_t f = frame(0x180u, 0u, 0u);
    unsigned m = 99;
    start();
    /* mailbox 0 completed (not collected yet), 1 and 2 busy */
    regs.TSR = CAEKF_BXCAN_TSR_TME(0) | CAEKF_BXCAN_TSR_RQCP(0) | CAEKF_BXCAN_TSR_TXOK(0);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_transmit(&can, &f, &m));
    TEST_ASSERT_EQUAL_UINT(0u, m);
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.tx_ok); /* counted before the refill erases it */
    /* TSR (RAM) still shows the old completion: the refilled mailbox is not counted again */
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_service(&can));
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.tx_ok);
    TEST_ASSERT_EQUAL_HEX32(CAEKF_BXCAN_TSR_TME(0) | CAEKF_BXCAN_TSR_RQCP(0) | CAEKF_BXCAN_TSR_TXOK(0), regs.TSR);
}

static void test_service_bus_off_and_error_state(void)
{
    caekf_bxcan_error_state_t es;
    start();
    regs.ESR = (200u << 24) | (130u << 16) | (3u << 4) | CAEKF_BXCAN_ESR_EPVF | CAEKF_BXCAN_ESR_EWGF;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_service(&can));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_error_state(&can, &es));
    TEST_ASSERT_EQUAL_UINT8(130u, es.tec);
    TEST_ASSERT_EQUAL_UINT8(200u, es.rec);
    TEST_ASSERT_EQUAL_UINT8(3u, es.lec);
    TEST_ASSERT_EQUAL_UINT8(1u, es.warning);
    TEST_ASSERT_EQUAL_UINT8(1u, es.passive);
    TEST_ASSERT_EQUAL_UINT8(0u, es.bus_off);
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.error_passive);
    regs.ESR = CAEKF_BXCAN_ESR_BOFF | CAEKF_BXCAN_ESR_EPVF;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_BUS_OFF, caekf_bxcan_service(&can));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_BUS_OFF, caekf_bxcan_service(&can));
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.bus_off); /* entries, not polls */
    regs.ESR = 0u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_service(&can));
    regs.ESR = CAEKF_BXCAN_ESR_BOFF;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_ERR_BUS_OFF, caekf_bxcan_service(&can));
    TEST_ASSERT_EQUAL_UINT32(2u, can.cnt.bus_off);
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.error_passive);
}

/* ---- the fake controller end to end with the driver ------------------------------------------ */

static void test_fake_round_trip_in_loopback(void)
{
    caekf_bxcan_config_t cfg;
    caekf_bxcan_frame_t f = frame(0x101u, 0u, 0u), g;
    config_500k(&cfg);
    cfg.loopback = 1u;
    cfg.wait_hook = caekf_bxcan_fake_hook;
    cfg.wait_ctx = &fake;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_init(&can, &fake.regs, &cfg));
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_filter_list16(&fake.regs, 0u, proto_ids, 6u, 0u, NULL));
    f.data[7] = 0xA5u;
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_transmit(&can, &f, NULL));
    caekf_bxcan_fake_step(&fake);
    TEST_ASSERT_EQUAL_UINT(1u, fake.tx_count);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_service(&can));
    TEST_ASSERT_EQUAL_UINT32(1u, can.cnt.tx_ok);
    TEST_ASSERT_EQUAL_INT(CAEKF_BXCAN_OK, caekf_bxcan_receive(&can, &g));
    TEST_ASSERT_EQUAL_HEX32(0x101u, g.id);
    TEST_ASSERT_EQUAL_HEX8(0xA5u, g.data[7]);
    TEST_ASSERT_EQUAL_UINT8(4u, g.fmi);
    start_fake(); /* re-init on the same fake works */
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_register_layout);
    RUN_TEST(test_timing_common_rates);
    RUN_TEST(test_timing_refusals);
    RUN_TEST(test_init_sequence);
    RUN_TEST(test_init_options_and_modes);
    RUN_TEST(test_init_never_acknowledged_times_out);
    RUN_TEST(test_init_sleep_never_left_times_out);
    RUN_TEST(test_init_preset_ack_then_start_timeout);
    RUN_TEST(test_init_refuses_bad_timing_untouched);
    RUN_TEST(test_filter_list16_bits);
    RUN_TEST(test_filter_list16_bank_and_fifo1);
    RUN_TEST(test_filter_refusals_leave_registers);
    RUN_TEST(test_filter_mask16_bits);
    RUN_TEST(test_filters_accept_what_they_should);
    RUN_TEST(test_transmit_fills_lowest_free_mailbox);
    RUN_TEST(test_transmit_follows_tme);
    RUN_TEST(test_transmit_extended_and_remote);
    RUN_TEST(test_transmit_refusals);
    RUN_TEST(test_receive_decodes_and_releases);
    RUN_TEST(test_receive_waits_for_a_pending_release);
    RUN_TEST(test_receive_empty_writes_nothing);
    RUN_TEST(test_receive_extended_remote_raw_dlc);
    RUN_TEST(test_receive_counts_and_clears_overrun);
    RUN_TEST(test_overrun_newest_wins);
    RUN_TEST(test_overrun_locked_fifo_keeps_oldest);
    RUN_TEST(test_service_counts_completions);
    RUN_TEST(test_refilled_mailbox_completion_counted_once);
    RUN_TEST(test_service_bus_off_and_error_state);
    RUN_TEST(test_fake_round_trip_in_loopback);
    return UNITY_END();
}
