/* Simulated bxCAN over a RAM register block: see bxcan_fake.h. */
#include "bxcan_fake.h"

#include <stddef.h>

#define BTR_RESET_VALUE 0x01230000u
#define TSR_MAILBOX_STATUS(m) \
    (CAEKF_BXCAN_TSR_RQCP(m) | CAEKF_BXCAN_TSR_TXOK(m) | CAEKF_BXCAN_TSR_ALST(m) | CAEKF_BXCAN_TSR_TERR(m))

void caekf_bxcan_fake_reset(caekf_bxcan_fake_t *f)
{
    /* cppcheck-suppress unassignedVariable ; static storage: all zero, the value it stands for */
    static const caekf_bxcan_fake_t zero;
    volatile uint32_t *w;
    size_t i;
    if (f == NULL) {
        return;
    }
    *f = zero;
    w = &f->regs.MCR;
    for (i = 0u; i < sizeof f->regs / sizeof(uint32_t); i++) {
        /* cppcheck-suppress objectIndex ; the register block is uint32_t words only: walked as an array */
        w[i] = 0u;
    }
    f->regs.MCR = CAEKF_BXCAN_MCR_RESET_VALUE;
    f->regs.MSR = CAEKF_BXCAN_MSR_RESET_VALUE;
    f->regs.TSR = CAEKF_BXCAN_TSR_RESET_VALUE;
    f->regs.BTR = BTR_RESET_VALUE;
    f->regs.FMR = CAEKF_BXCAN_FMR_RESET_VALUE;
    f->tsr_state = CAEKF_BXCAN_TSR_RESET_VALUE;
    f->pub_tsr = CAEKF_BXCAN_TSR_RESET_VALUE;
    f->pub_rf0r = 0u;
    f->ack_init = 1u;
    f->ack_leave = 1u;
}

static int normal_mode(const caekf_bxcan_fake_t *f)
{
    return (f->regs.MSR & (CAEKF_BXCAN_MSR_INAK | CAEKF_BXCAN_MSR_SLAK)) == 0u;
}

static uint32_t pack4(const uint8_t *d)
{
    return (uint32_t)d[0] | ((uint32_t)d[1] << 8) | ((uint32_t)d[2] << 16) | ((uint32_t)d[3] << 24);
}

static void publish_rx(caekf_bxcan_fake_t *f)
{
    uint32_t rf = (uint32_t)f->fifo_count;
    if (f->full_flag) {
        rf |= CAEKF_BXCAN_RFR_FULL;
    }
    if (f->fovr_flag) {
        rf |= CAEKF_BXCAN_RFR_FOVR;
    }
    if (f->fifo_count > 0u) {
        const caekf_bxcan_frame_t *fr = &f->fifo[0];
        caekf_bxcan_rx_mailbox_t *mb = &f->regs.rx[0];
        uint32_t rir = fr->ide ? ((fr->id << CAEKF_BXCAN_IR_EXID_SHIFT) | CAEKF_BXCAN_IR_IDE)
                               : (fr->id << CAEKF_BXCAN_IR_STID_SHIFT);
        if (fr->rtr) {
            rir |= CAEKF_BXCAN_IR_RTR;
        }
        mb->RIR = rir;
        mb->RDTR = ((uint32_t)fr->time << CAEKF_BXCAN_DTR_TIME_SHIFT) |
                   ((uint32_t)fr->fmi << CAEKF_BXCAN_RDTR_FMI_SHIFT) | ((uint32_t)fr->dlc & CAEKF_BXCAN_DTR_DLC_MASK);
        mb->RDLR = pack4(&fr->data[0]);
        mb->RDHR = pack4(&fr->data[4]);
    }
    f->regs.RF0R = rf;
    f->pub_rf0r = rf;
}

/* The driver's writes to the w1c / release bits since the model last published them. */
static void apply_writes(caekf_bxcan_fake_t *f)
{
    uint32_t cur = f->regs.TSR;
    /* cppcheck-suppress variableScope ; declarations at the top of the block are this file's style */
    unsigned m, k;
    if (cur != f->pub_tsr) {
        for (m = 0u; m < CAEKF_BXCAN_TX_MAILBOXES; m++) {
            if (cur & CAEKF_BXCAN_TSR_RQCP(m)) {
                f->tsr_state &= ~TSR_MAILBOX_STATUS(m);
            }
        }
        f->regs.TSR = f->tsr_state;
        f->pub_tsr = f->tsr_state;
    }
    cur = f->regs.RF0R;
    if (cur != f->pub_rf0r) {
        if (cur & CAEKF_BXCAN_RFR_FULL) {
            f->full_flag = 0u;
        }
        if (cur & CAEKF_BXCAN_RFR_FOVR) {
            f->fovr_flag = 0u;
        }
        if ((cur & CAEKF_BXCAN_RFR_RFOM) && f->fifo_count > 0u) {
            for (k = 1u; k < f->fifo_count; k++) {
                f->fifo[k - 1u] = f->fifo[k];
            }
            f->fifo_count--;
        }
        publish_rx(f);
    }
}

int caekf_bxcan_fake_match(const caekf_bxcan_fake_t *f, const caekf_bxcan_frame_t *frame, unsigned *fifo, unsigned *fmi)
{
    const caekf_bxcan_regs_t *r;
    uint32_t w32, w16, fa, fm, fs, ffa;
    unsigned bank, nbanks, num[2] = {0u, 0u};
    unsigned best_class = 4u, best_fifo = 0u, best_num = 0u;
    if (f == NULL || frame == NULL) {
        return 0;
    }
    r = &f->regs;
    nbanks = (unsigned)((r->FMR & CAEKF_BXCAN_FMR_CAN2SB_MASK) >> CAEKF_BXCAN_FMR_CAN2SB_SHIFT); /* CAN1's banks */
    if (nbanks > CAEKF_BXCAN_FILTER_BANKS) {
        nbanks = CAEKF_BXCAN_FILTER_BANKS;
    }
    if (r->FMR & CAEKF_BXCAN_FMR_FINIT) {
        return 0; /* filter initialisation mode: reception is deactivated */
    }
    if (frame->ide) {
        w32 = (frame->id << CAEKF_BXCAN_IR_EXID_SHIFT) | CAEKF_BXCAN_IR_IDE;
        w16 = (((frame->id >> 18) & 0x7FFu) << CAEKF_BXCAN_F16_STID_SHIFT) | CAEKF_BXCAN_F16_IDE |
              ((frame->id >> 15) & 7u);
    } else {
        w32 = frame->id << CAEKF_BXCAN_IR_STID_SHIFT;
        w16 = frame->id << CAEKF_BXCAN_F16_STID_SHIFT;
    }
    if (frame->rtr) {
        w32 |= CAEKF_BXCAN_IR_RTR;
        w16 |= CAEKF_BXCAN_F16_RTR;
    }
    fa = r->FA1R;
    fm = r->FM1R;
    fs = r->FS1R;
    ffa = r->FFA1R;
    for (bank = 0u; bank < nbanks; bank++) {
        uint32_t bit = 1u << bank, r1 = r->filter[bank].FR1, r2 = r->filter[bank].FR2;
        unsigned bfifo = (ffa & bit) ? 1u : 0u, list = (fm & bit) ? 1u : 0u, s32 = (fs & bit) ? 1u : 0u;
        unsigned n = s32 ? (list ? 2u : 1u) : (list ? 4u : 2u);
        unsigned cls = s32 ? (list ? 0u : 1u) : (list ? 2u : 3u);
        unsigned base = num[bfifo], k;
        num[bfifo] += n; /* numbering ignores the activation state */
        if (!(fa & bit)) {
            continue;
        }
        for (k = 0u; k < n; k++) {
            int hit;
            if (s32) {
                hit = list ? (((w32 ^ (k == 0u ? r1 : r2)) & ~1u) == 0u) : (((w32 ^ r1) & r2 & ~1u) == 0u);
            } else if (list) {
                uint32_t v = ((k < 2u ? r1 : r2) >> (16u * (k & 1u))) & 0xFFFFu;
                hit = w16 == v;
            } else {
                uint32_t reg = k == 0u ? r1 : r2;
                hit = ((w16 ^ (reg & 0xFFFFu)) & (reg >> 16)) == 0u;
            }
            /* priority: 32-bit over 16-bit, list over mask, then the lower number (first found) */
            if (hit && cls < best_class) {
                best_class = cls;
                best_fifo = bfifo;
                best_num = base + k;
            }
        }
    }
    if (best_class == 4u) {
        return 0;
    }
    if (fifo != NULL) {
        *fifo = best_fifo;
    }
    if (fmi != NULL) {
        *fmi = best_num;
    }
    return 1;
}

int caekf_bxcan_fake_deliver(caekf_bxcan_fake_t *f, const caekf_bxcan_frame_t *frame)
{
    caekf_bxcan_frame_t fr;
    unsigned fifo = 0u, fmi = 0u;
    if (f == NULL || frame == NULL) {
        return 0;
    }
    apply_writes(f);
    if (!normal_mode(f)) {
        f->rx_offline++;
        return 0;
    }
    if (!caekf_bxcan_fake_match(f, frame, &fifo, &fmi)) {
        f->rx_filtered++;
        return 0;
    }
    if (fifo != 0u) {
        f->rx_fifo1++;
        return 0;
    }
    fr = *frame;
    fr.fmi = (uint8_t)fmi;
    if (f->fifo_count < CAEKF_BXCAN_RX_FIFO_DEPTH) {
        f->fifo[f->fifo_count++] = fr;
        f->rx_delivered++;
        if (f->fifo_count == CAEKF_BXCAN_RX_FIFO_DEPTH) {
            f->full_flag = 1u;
        }
        publish_rx(f);
        return 1;
    }
    f->fovr_flag = 1u;
    f->rx_lost++;
    if (!(f->regs.MCR & CAEKF_BXCAN_MCR_RFLM)) {
        f->fifo[CAEKF_BXCAN_RX_FIFO_DEPTH - 1u] = fr; /* not locked: the newest overwrites the last */
    }
    publish_rx(f);
    return -1;
}

static void unpack4(uint32_t w, uint8_t *d)
{
    d[0] = (uint8_t)(w & 0xFFu);
    d[1] = (uint8_t)((w >> 8) & 0xFFu);
    d[2] = (uint8_t)((w >> 16) & 0xFFu);
    d[3] = (uint8_t)((w >> 24) & 0xFFu);
}

void caekf_bxcan_fake_step(caekf_bxcan_fake_t *f)
{
    uint32_t mcr, msr;
    unsigned m;
    if (f == NULL) {
        return;
    }
    f->steps++;
    mcr = f->regs.MCR;
    msr = f->regs.MSR;
    if (mcr & CAEKF_BXCAN_MCR_INRQ) {
        if (f->ack_init) {
            msr = (msr | CAEKF_BXCAN_MSR_INAK) & ~CAEKF_BXCAN_MSR_SLAK;
        }
    } else if (mcr & CAEKF_BXCAN_MCR_SLEEP) {
        if (f->ack_init) {
            msr = (msr | CAEKF_BXCAN_MSR_SLAK) & ~CAEKF_BXCAN_MSR_INAK;
        }
    } else if (f->ack_leave) {
        msr &= ~(CAEKF_BXCAN_MSR_INAK | CAEKF_BXCAN_MSR_SLAK);
    }
    f->regs.MSR = msr;

    apply_writes(f);
    for (m = 0u; m < CAEKF_BXCAN_TX_MAILBOXES; m++) {
        caekf_bxcan_tx_mailbox_t *mb = &f->regs.tx[m];
        uint32_t tir = mb->TIR;
        caekf_bxcan_frame_t fr;
        if (!(tir & CAEKF_BXCAN_IR_TXRQ)) {
            continue;
        }
        f->tsr_state &= ~TSR_MAILBOX_STATUS(m); /* a new request clears RQCP and friends */
        if (!normal_mode(f)) {
            f->tsr_state &= ~CAEKF_BXCAN_TSR_TME(m); /* pending until normal mode */
            continue;
        }
        fr.ide = (uint8_t)((tir & CAEKF_BXCAN_IR_IDE) != 0u);
        fr.rtr = (uint8_t)((tir & CAEKF_BXCAN_IR_RTR) != 0u);
        fr.id = fr.ide ? (tir >> CAEKF_BXCAN_IR_EXID_SHIFT) : (tir >> CAEKF_BXCAN_IR_STID_SHIFT);
        fr.dlc = (uint8_t)(mb->TDTR & CAEKF_BXCAN_DTR_DLC_MASK);
        fr.fmi = 0u;
        fr.time = 0u;
        unpack4(mb->TDLR, &fr.data[0]);
        unpack4(mb->TDHR, &fr.data[4]);
        if (f->tx_count < CAEKF_BXCAN_FAKE_TX_LOG) {
            f->tx_log[f->tx_count++] = fr;
        }
        f->tx_total++;
        mb->TIR = tir & ~CAEKF_BXCAN_IR_TXRQ;
        f->tsr_state |= CAEKF_BXCAN_TSR_TME(m) | CAEKF_BXCAN_TSR_RQCP(m) | CAEKF_BXCAN_TSR_TXOK(m);
        if (f->regs.BTR & CAEKF_BXCAN_BTR_LBKM) {
            (void)caekf_bxcan_fake_deliver(f, &fr);
        }
    }
    /* CODE: the next free mailbox (lowest empty one). */
    f->tsr_state &= ~CAEKF_BXCAN_TSR_CODE_MASK;
    for (m = 0u; m < CAEKF_BXCAN_TX_MAILBOXES; m++) {
        if (f->tsr_state & CAEKF_BXCAN_TSR_TME(m)) {
            f->tsr_state |= (uint32_t)m << CAEKF_BXCAN_TSR_CODE_SHIFT;
            break;
        }
    }
    f->regs.TSR = f->tsr_state;
    f->pub_tsr = f->tsr_state;
    publish_rx(f);
}

void caekf_bxcan_fake_hook(void *ctx) { caekf_bxcan_fake_step((caekf_bxcan_fake_t *)ctx); }
