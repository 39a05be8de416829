/* bxCAN register-level driver: see bxcan.h. */
#include "bxcan.h"

#include <stddef.h>

#define STD_ID_MAX 0x7FFu
#define EXT_ID_MAX 0x1FFFFFFFu
#define CLASSIC_DLC_MAX 8u

caekf_bxcan_status_t caekf_bxcan_config_default(caekf_bxcan_config_t *cfg)
{
    if (cfg == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    cfg->timing.prescaler = 0u;
    cfg->timing.ts1 = 0u;
    cfg->timing.ts2 = 0u;
    cfg->timing.sjw = 0u;
    cfg->tx_fifo_order = 1u;
    cfg->auto_bus_off_recovery = 1u;
    cfg->no_auto_retransmit = 0u;
    cfg->rx_fifo_locked = 0u;
    cfg->loopback = 0u;
    cfg->silent = 0u;
    cfg->wait_limit = 0u;
    cfg->wait_hook = NULL;
    cfg->wait_ctx = NULL;
    return CAEKF_BXCAN_OK;
}

caekf_bxcan_status_t caekf_bxcan_timing_btr(const caekf_bxcan_timing_t *t, uint32_t *btr)
{
    if (t == NULL || btr == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    if (t->prescaler < 1u || t->prescaler > 1024u || t->ts1 < 1u || t->ts1 > 16u || t->ts2 < 1u || t->ts2 > 8u ||
        t->sjw < 1u || t->sjw > 4u || t->sjw > t->ts2) {
        return CAEKF_BXCAN_ERR_PARAM;
    }
    *btr = ((uint32_t)(t->sjw - 1u) << CAEKF_BXCAN_BTR_SJW_SHIFT) |
           ((uint32_t)(t->ts2 - 1u) << CAEKF_BXCAN_BTR_TS2_SHIFT) |
           ((uint32_t)(t->ts1 - 1u) << CAEKF_BXCAN_BTR_TS1_SHIFT) |
           ((uint32_t)(t->prescaler - 1u) << CAEKF_BXCAN_BTR_BRP_SHIFT);
    return CAEKF_BXCAN_OK;
}

caekf_bxcan_status_t caekf_bxcan_timing_compute(uint32_t pclk_hz, uint32_t bitrate, uint32_t sample_permille,
                                                caekf_bxcan_timing_t *t)
{
    uint32_t tq;
    uint32_t best_err = 0u, best_tq = 0u;
    caekf_bxcan_timing_t best = {0u, 0u, 0u, 0u};
    if (t == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    if (pclk_hz == 0u || bitrate == 0u || bitrate > 1000000u || sample_permille < 500u || sample_permille > 950u) {
        return CAEKF_BXCAN_ERR_PARAM;
    }
    for (tq = 25u; tq >= 8u; tq--) { /* bitrate * tq <= 25e6: no overflow */
        uint32_t div = bitrate * tq, presc, before, ts1, ts2, err;
        if (pclk_hz % div != 0u) {
            continue;
        }
        presc = pclk_hz / div;
        if (presc < 1u || presc > 1024u) {
            continue;
        }
        before = (tq * sample_permille + 500u) / 1000u; /* quanta up to the sample point: 1 + ts1 */
        ts1 = before - 1u;
        if (ts1 > 16u) {
            ts1 = 16u;
        }
        ts2 = tq - 1u - ts1;
        if (ts2 < 1u) {
            ts2 = 1u;
            ts1 = tq - 2u;
        }
        if (ts2 > 8u) {
            ts2 = 8u;
            ts1 = tq - 9u;
        }
        if (ts1 < 1u || ts1 > 16u) {
            continue;
        }
        /* |sample point - target| in permille, scaled by tq (compare err/tq across candidates) */
        err = (1000u * (1u + ts1) > sample_permille * tq) ? 1000u * (1u + ts1) - sample_permille * tq
                                                          : sample_permille * tq - 1000u * (1u + ts1);
        if (best_tq == 0u || err * best_tq < best_err * tq) {
            best_err = err;
            best_tq = tq;
            best.prescaler = (uint16_t)presc;
            best.ts1 = (uint8_t)ts1;
            best.ts2 = (uint8_t)ts2;
            best.sjw = 1u;
        }
    }
    if (best_tq == 0u) {
        return CAEKF_BXCAN_ERR_PARAM;
    }
    *t = best;
    return CAEKF_BXCAN_OK;
}

/* Waits until (MSR & mask) == value: at most can->wait_limit reads, the hook between reads. */
static int wait_msr(const caekf_bxcan_t *can, uint32_t mask, uint32_t value)
{
    uint32_t i;
    for (i = 0u; i < can->wait_limit; i++) {
        if ((can->regs->MSR & mask) == value) {
            return 1;
        }
        if (can->wait_hook != NULL) {
            can->wait_hook(can->wait_ctx);
        }
    }
    return (can->regs->MSR & mask) == value;
}

caekf_bxcan_status_t caekf_bxcan_init(caekf_bxcan_t *can, caekf_bxcan_regs_t *regs, const caekf_bxcan_config_t *cfg)
{
    /* cppcheck-suppress unassignedVariable ; static storage: all zero, the value it stands for */
    static const caekf_bxcan_counters_t zero_counters;
    uint32_t btr, mcr;
    caekf_bxcan_regs_t *r = regs;
    if (can == NULL || regs == NULL || cfg == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    can->started = 0u;
    if (caekf_bxcan_timing_btr(&cfg->timing, &btr) != CAEKF_BXCAN_OK) {
        return CAEKF_BXCAN_ERR_PARAM;
    }
    if (cfg->loopback) {
        btr |= CAEKF_BXCAN_BTR_LBKM;
    }
    if (cfg->silent) {
        btr |= CAEKF_BXCAN_BTR_SILM;
    }
    can->regs = regs;
    can->cnt = zero_counters;
    can->wait_limit = cfg->wait_limit != 0u ? cfg->wait_limit : CAEKF_BXCAN_DEFAULT_WAIT_LIMIT;
    can->wait_hook = cfg->wait_hook;
    can->wait_ctx = cfg->wait_ctx;
    can->in_bus_off = 0u;
    can->in_error_passive = 0u;

    /* Out of sleep (the reset state), into initialisation: INAK set and SLAK clear. */
    r->MCR = (r->MCR & ~CAEKF_BXCAN_MCR_SLEEP) | CAEKF_BXCAN_MCR_INRQ;
    if (!wait_msr(can, CAEKF_BXCAN_MSR_INAK | CAEKF_BXCAN_MSR_SLAK, CAEKF_BXCAN_MSR_INAK)) {
        return CAEKF_BXCAN_ERR_INIT_TIMEOUT;
    }

    mcr = CAEKF_BXCAN_MCR_INRQ | (r->MCR & CAEKF_BXCAN_MCR_DBF); /* TTCM, AWUM, SLEEP off */
    if (cfg->tx_fifo_order) {
        mcr |= CAEKF_BXCAN_MCR_TXFP;
    }
    if (cfg->rx_fifo_locked) {
        mcr |= CAEKF_BXCAN_MCR_RFLM;
    }
    if (cfg->no_auto_retransmit) {
        mcr |= CAEKF_BXCAN_MCR_NART;
    }
    if (cfg->auto_bus_off_recovery) {
        mcr |= CAEKF_BXCAN_MCR_ABOM;
    }
    r->MCR = mcr;
    r->IER = 0u; /* polled driver */
    r->BTR = btr;

    /* Normal mode: the controller acknowledges after 11 recessive bits on RX (bus idle). */
    r->MCR = mcr & ~CAEKF_BXCAN_MCR_INRQ;
    if (!wait_msr(can, CAEKF_BXCAN_MSR_INAK, 0u)) {
        return CAEKF_BXCAN_ERR_START_TIMEOUT;
    }
    can->started = 1u;
    return CAEKF_BXCAN_OK;
}

/* ---- filters ------------------------------------------------------------------------------- */

static uint32_t f16_std(uint16_t id)
{
    return (uint32_t)id << CAEKF_BXCAN_F16_STID_SHIFT; /* RTR 0, IDE 0, EXID[17:15] 0 */
}

/* Puts a bank in the given mode (list 1 / mask 0), 16-bit scale and FIFO, deactivated. */
static void bank_prepare(caekf_bxcan_regs_t *r, unsigned bank, unsigned list, unsigned fifo)
{
    uint32_t bit = 1u << bank;
    r->FA1R &= ~bit;
    r->FS1R &= ~bit;
    if (list) {
        r->FM1R |= bit;
    } else {
        r->FM1R &= ~bit;
    }
    if (fifo) {
        r->FFA1R |= bit;
    } else {
        r->FFA1R &= ~bit;
    }
}

caekf_bxcan_status_t caekf_bxcan_filter_list16(caekf_bxcan_regs_t *regs, unsigned first_bank, const uint16_t *ids,
                                               unsigned n_ids, unsigned fifo, unsigned *banks_used)
{
    unsigned i, b, banks;
    if (regs == NULL || ids == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    if (n_ids == 0u || fifo > 1u || first_bank >= CAEKF_BXCAN_FILTER_BANKS ||
        n_ids > 4u * (CAEKF_BXCAN_FILTER_BANKS - first_bank)) {
        return CAEKF_BXCAN_ERR_PARAM;
    }
    for (i = 0u; i < n_ids; i++) {
        if (ids[i] > STD_ID_MAX) {
            return CAEKF_BXCAN_ERR_PARAM;
        }
    }
    banks = (n_ids + 3u) / 4u;
    regs->FMR |= CAEKF_BXCAN_FMR_FINIT;
    for (b = 0u; b < banks; b++) {
        uint32_t w[4];
        unsigned k, bank = first_bank + b;
        for (k = 0u; k < 4u; k++) {
            unsigned idx = 4u * b + k;
            w[k] = f16_std(ids[idx < n_ids ? idx : n_ids - 1u]); /* pad with the last identifier */
        }
        bank_prepare(regs, bank, 1u, fifo);
        regs->filter[bank].FR1 = w[0] | (w[1] << 16);
        regs->filter[bank].FR2 = w[2] | (w[3] << 16);
        regs->FA1R |= 1u << bank;
    }
    regs->FMR &= ~CAEKF_BXCAN_FMR_FINIT;
    if (banks_used != NULL) {
        *banks_used = banks;
    }
    return CAEKF_BXCAN_OK;
}

caekf_bxcan_status_t caekf_bxcan_filter_mask16(caekf_bxcan_regs_t *regs, unsigned bank, const uint16_t id[2],
                                               const uint16_t mask[2], unsigned fifo)
{
    uint32_t w[2];
    unsigned k;
    if (regs == NULL || id == NULL || mask == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    if (bank >= CAEKF_BXCAN_FILTER_BANKS || fifo > 1u) {
        return CAEKF_BXCAN_ERR_PARAM;
    }
    for (k = 0u; k < 2u; k++) {
        if (id[k] > STD_ID_MAX || mask[k] > STD_ID_MAX) {
            return CAEKF_BXCAN_ERR_PARAM;
        }
        w[k] = f16_std(id[k]) | ((f16_std(mask[k]) | CAEKF_BXCAN_F16_RTR | CAEKF_BXCAN_F16_IDE) << 16);
    }
    regs->FMR |= CAEKF_BXCAN_FMR_FINIT;
    bank_prepare(regs, bank, 0u, fifo);
    regs->filter[bank].FR1 = w[0];
    regs->filter[bank].FR2 = w[1];
    regs->FA1R |= 1u << bank;
    regs->FMR &= ~CAEKF_BXCAN_FMR_FINIT;
    return CAEKF_BXCAN_OK;
}

caekf_bxcan_status_t caekf_bxcan_filter_deactivate(caekf_bxcan_regs_t *regs, unsigned first_bank, unsigned count)
{
    unsigned b;
    if (regs == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    if (first_bank > CAEKF_BXCAN_FILTER_BANKS || count > CAEKF_BXCAN_FILTER_BANKS - first_bank) {
        return CAEKF_BXCAN_ERR_PARAM;
    }
    regs->FMR |= CAEKF_BXCAN_FMR_FINIT;
    for (b = first_bank; b < first_bank + count; b++) {
        regs->FA1R &= ~(1u << b);
    }
    regs->FMR &= ~CAEKF_BXCAN_FMR_FINIT;
    return CAEKF_BXCAN_OK;
}

/* ---- transmit / receive ----------------------------------------------------------------------- */

static int mailbox_free(const caekf_bxcan_regs_t *r, uint32_t tsr, unsigned m)
{
    return (tsr & CAEKF_BXCAN_TSR_TME(m)) != 0u && (r->tx[m].TIR & CAEKF_BXCAN_IR_TXRQ) == 0u;
}

/* Counts the completed request of mailbox m if TSR shows one: RQCP set on an empty mailbox (RQCP is
 * cleared by hardware when a new request is made, so a refilled mailbox has none). 1 if counted. */
static int account_completion(caekf_bxcan_t *can, uint32_t tsr, unsigned m)
{
    if ((tsr & CAEKF_BXCAN_TSR_RQCP(m)) == 0u || !mailbox_free(can->regs, tsr, m)) {
        return 0;
    }
    if (tsr & CAEKF_BXCAN_TSR_TXOK(m)) {
        can->cnt.tx_ok++;
    } else {
        can->cnt.tx_failed++;
    }
    if (tsr & CAEKF_BXCAN_TSR_ALST(m)) {
        can->cnt.tx_arb_lost++;
    }
    return 1;
}

unsigned caekf_bxcan_free_mailboxes(const caekf_bxcan_t *can)
{
    unsigned m, n = 0u;
    uint32_t tsr;
    if (can == NULL || can->regs == NULL) {
        return 0u;
    }
    tsr = can->regs->TSR;
    for (m = 0u; m < CAEKF_BXCAN_TX_MAILBOXES; m++) {
        n += (unsigned)mailbox_free(can->regs, tsr, m);
    }
    return n;
}

static uint32_t pack4(const uint8_t *d)
{
    return (uint32_t)d[0] | ((uint32_t)d[1] << 8) | ((uint32_t)d[2] << 16) | ((uint32_t)d[3] << 24);
}

static void unpack4(uint32_t w, uint8_t *d)
{
    d[0] = (uint8_t)(w & 0xFFu);
    d[1] = (uint8_t)((w >> 8) & 0xFFu);
    d[2] = (uint8_t)((w >> 16) & 0xFFu);
    d[3] = (uint8_t)((w >> 24) & 0xFFu);
}

caekf_bxcan_status_t caekf_bxcan_transmit(caekf_bxcan_t *can, const caekf_bxcan_frame_t *frame, unsigned *mailbox)
{
    caekf_bxcan_regs_t *r;
    caekf_bxcan_tx_mailbox_t *mb;
    uint32_t tsr, tir;
    unsigned m;
    if (can == NULL || frame == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    if (!can->started) {
        return CAEKF_BXCAN_ERR_STATE;
    }
    if (frame->dlc > CLASSIC_DLC_MAX || frame->id > (frame->ide ? EXT_ID_MAX : STD_ID_MAX)) {
        return CAEKF_BXCAN_ERR_PARAM;
    }
    r = can->regs;
    if (r->ESR & CAEKF_BXCAN_ESR_BOFF) {
        can->cnt.bus_off_refused++;
        return CAEKF_BXCAN_ERR_BUS_OFF;
    }
    tsr = r->TSR;
    for (m = 0u; m < CAEKF_BXCAN_TX_MAILBOXES; m++) {
        if (mailbox_free(r, tsr, m)) {
            break;
        }
    }
    if (m == CAEKF_BXCAN_TX_MAILBOXES) {
        can->cnt.tx_busy++;
        return CAEKF_BXCAN_BUSY;
    }
    /* Refilling clears the mailbox's RQCP in hardware: count its last completion first. */
    (void)account_completion(can, tsr, m);
    mb = &r->tx[m];
    mb->TDTR = (uint32_t)frame->dlc; /* TGT 0 */
    mb->TDLR = pack4(&frame->data[0]);
    mb->TDHR = pack4(&frame->data[4]);
    tir = frame->ide ? ((frame->id << CAEKF_BXCAN_IR_EXID_SHIFT) | CAEKF_BXCAN_IR_IDE)
                     : (frame->id << CAEKF_BXCAN_IR_STID_SHIFT);
    if (frame->rtr) {
        tir |= CAEKF_BXCAN_IR_RTR;
    }
    mb->TIR = tir | CAEKF_BXCAN_IR_TXRQ; /* identifier and request last: data and DLC are in place */
    can->cnt.tx_requests++;
    if (mailbox != NULL) {
        *mailbox = m;
    }
    return CAEKF_BXCAN_OK;
}

caekf_bxcan_status_t caekf_bxcan_receive(caekf_bxcan_t *can, caekf_bxcan_frame_t *frame)
{
    caekf_bxcan_regs_t *r;
    const caekf_bxcan_rx_mailbox_t *mb;
    uint32_t rf, flags, rir, rdtr;
    unsigned spin;
    if (can == NULL || frame == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    if (!can->started) {
        return CAEKF_BXCAN_ERR_STATE;
    }
    r = can->regs;
    rf = r->RF0R;
    /* A release still in progress: the output mailbox is not the next message yet. */
    for (spin = 0u; (rf & CAEKF_BXCAN_RFR_RFOM) != 0u && spin < CAEKF_BXCAN_RFOM_SPIN; spin++) {
        if (can->wait_hook != NULL) {
            can->wait_hook(can->wait_ctx);
        }
        rf = r->RF0R;
    }
    if (rf & CAEKF_BXCAN_RFR_RFOM) {
        return CAEKF_BXCAN_EMPTY;
    }
    flags = rf & (CAEKF_BXCAN_RFR_FULL | CAEKF_BXCAN_RFR_FOVR);
    if (flags & CAEKF_BXCAN_RFR_FOVR) {
        can->cnt.rx_overruns++;
    }
    if (flags & CAEKF_BXCAN_RFR_FULL) {
        can->cnt.rx_full++;
    }
    if ((rf & CAEKF_BXCAN_RFR_FMP_MASK) == 0u) {
        if (flags != 0u) {
            r->RF0R = flags; /* rc_w1 */
        }
        return CAEKF_BXCAN_EMPTY;
    }
    mb = &r->rx[0];
    rir = mb->RIR;
    rdtr = mb->RDTR;
    unpack4(mb->RDLR, &frame->data[0]);
    unpack4(mb->RDHR, &frame->data[4]);
    frame->ide = (uint8_t)((rir & CAEKF_BXCAN_IR_IDE) != 0u);
    frame->rtr = (uint8_t)((rir & CAEKF_BXCAN_IR_RTR) != 0u);
    frame->id = frame->ide ? (rir >> CAEKF_BXCAN_IR_EXID_SHIFT) : (rir >> CAEKF_BXCAN_IR_STID_SHIFT);
    frame->dlc = (uint8_t)(rdtr & CAEKF_BXCAN_DTR_DLC_MASK);
    frame->fmi = (uint8_t)((rdtr >> CAEKF_BXCAN_RDTR_FMI_SHIFT) & 0xFFu);
    frame->time = (uint16_t)(rdtr >> CAEKF_BXCAN_DTR_TIME_SHIFT);
    r->RF0R = CAEKF_BXCAN_RFR_RFOM | flags; /* release, and clear the flags seen, in one write */
    can->cnt.rx_frames++;
    return CAEKF_BXCAN_OK;
}

caekf_bxcan_status_t caekf_bxcan_service(caekf_bxcan_t *can)
{
    caekf_bxcan_regs_t *r;
    uint32_t tsr, esr, ack = 0u;
    unsigned m;
    uint8_t boff, epv;
    if (can == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    if (!can->started) {
        return CAEKF_BXCAN_ERR_STATE;
    }
    r = can->regs;
    tsr = r->TSR;
    for (m = 0u; m < CAEKF_BXCAN_TX_MAILBOXES; m++) {
        if (account_completion(can, tsr, m)) {
            ack |= CAEKF_BXCAN_TSR_RQCP(m);
        }
    }
    if (ack != 0u) {
        r->TSR = ack; /* rc_w1: also clears TXOK, ALST, TERR of those mailboxes */
    }
    esr = r->ESR;
    boff = (uint8_t)((esr & CAEKF_BXCAN_ESR_BOFF) != 0u);
    epv = (uint8_t)((esr & CAEKF_BXCAN_ESR_EPVF) != 0u);
    if (boff && !can->in_bus_off) {
        can->cnt.bus_off++;
    }
    if (epv && !can->in_error_passive) {
        can->cnt.error_passive++;
    }
    can->in_bus_off = boff;
    can->in_error_passive = epv;
    return boff ? CAEKF_BXCAN_ERR_BUS_OFF : CAEKF_BXCAN_OK;
}

caekf_bxcan_status_t caekf_bxcan_error_state(const caekf_bxcan_t *can, caekf_bxcan_error_state_t *st)
{
    uint32_t esr;
    if (can == NULL || can->regs == NULL || st == NULL) {
        return CAEKF_BXCAN_ERR_NULL;
    }
    esr = can->regs->ESR;
    st->tec = (uint8_t)((esr >> CAEKF_BXCAN_ESR_TEC_SHIFT) & 0xFFu);
    st->rec = (uint8_t)((esr >> CAEKF_BXCAN_ESR_REC_SHIFT) & 0xFFu);
    st->lec = (uint8_t)((esr & CAEKF_BXCAN_ESR_LEC_MASK) >> CAEKF_BXCAN_ESR_LEC_SHIFT);
    st->warning = (uint8_t)((esr & CAEKF_BXCAN_ESR_EWGF) != 0u);
    st->passive = (uint8_t)((esr & CAEKF_BXCAN_ESR_EPVF) != 0u);
    st->bus_off = (uint8_t)((esr & CAEKF_BXCAN_ESR_BOFF) != 0u);
    return CAEKF_BXCAN_OK;
}

const char *caekf_bxcan_status_str(caekf_bxcan_status_t st)
{
    switch (st) {
    case CAEKF_BXCAN_OK: return "ok";
    case CAEKF_BXCAN_EMPTY: return "empty";
    case CAEKF_BXCAN_BUSY: return "busy";
    case CAEKF_BXCAN_ERR_NULL: return "null pointer";
    case CAEKF_BXCAN_ERR_PARAM: return "parameter out of range";
    case CAEKF_BXCAN_ERR_INIT_TIMEOUT: return "initialisation mode not acknowledged";
    case CAEKF_BXCAN_ERR_START_TIMEOUT: return "normal mode not acknowledged (bus idle never seen)";
    case CAEKF_BXCAN_ERR_STATE: return "not started";
    case CAEKF_BXCAN_ERR_BUS_OFF: return "bus-off";
    }
    return "unknown";
}
