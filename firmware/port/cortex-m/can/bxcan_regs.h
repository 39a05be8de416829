/*
 * bxcan_regs.h - register map of the STM32 bxCAN controller (STM32F4 RM0090, STM32F7 RM0385/RM0410,
 * chapter "Controller area network (bxCAN)"), written from the register descriptions of the
 * reference manuals. No vendor header: a struct overlay of 32-bit registers plus the bit fields the
 * driver uses. The overlay's address is always given by the caller (the peripheral on a part, a RAM
 * block in the tests), so nothing here assumes a fixed address; the CAEKF_BXCAN*_BASE constants are
 * the usual ones for convenience.
 *
 * Filter registers (FMR .. filter banks) exist only in the master instance (CAN1); CAN2 uses the
 * banks from FMR.CAN2SB upwards through CAN1's registers. CAN3 of the STM32F76x/77x has its own 14.
 */
#ifndef CAEKF_BXCAN_REGS_H
#define CAEKF_BXCAN_REGS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define CAEKF_BXCAN1_BASE 0x40006400u /* STM32F4 / STM32F7 CAN1 (master: owns the filter banks) */
#define CAEKF_BXCAN2_BASE 0x40006800u /* STM32F4 / STM32F7 CAN2 (slave) */
#define CAEKF_BXCAN3_BASE 0x40003400u /* STM32F76x/77x CAN3 (own 14 filter banks) */

#define CAEKF_BXCAN_TX_MAILBOXES 3u
#define CAEKF_BXCAN_RX_FIFOS 2u
#define CAEKF_BXCAN_RX_FIFO_DEPTH 3u
#define CAEKF_BXCAN_FILTER_BANKS 28u /* dual-CAN parts; single-CAN parts have 14 (banks 0..13) */

typedef struct {
    volatile uint32_t TIR;  /* identifier, IDE, RTR, TXRQ */
    volatile uint32_t TDTR; /* DLC, TGT, TIME */
    volatile uint32_t TDLR; /* data bytes 0..3 (byte 0 in bits 7:0) */
    volatile uint32_t TDHR; /* data bytes 4..7 */
} caekf_bxcan_tx_mailbox_t;

typedef struct {
    volatile uint32_t RIR;  /* identifier, IDE, RTR (read only) */
    volatile uint32_t RDTR; /* DLC, FMI, TIME */
    volatile uint32_t RDLR; /* data bytes 0..3 */
    volatile uint32_t RDHR; /* data bytes 4..7 */
} caekf_bxcan_rx_mailbox_t;

typedef struct {
    volatile uint32_t FR1;
    volatile uint32_t FR2;
} caekf_bxcan_filter_bank_t;

typedef struct {
    volatile uint32_t MCR;                                 /* 0x000 master control */
    volatile uint32_t MSR;                                 /* 0x004 master status */
    volatile uint32_t TSR;                                 /* 0x008 transmit status */
    volatile uint32_t RF0R;                                /* 0x00C receive FIFO 0 */
    volatile uint32_t RF1R;                                /* 0x010 receive FIFO 1 */
    volatile uint32_t IER;                                 /* 0x014 interrupt enable */
    volatile uint32_t ESR;                                 /* 0x018 error status */
    volatile uint32_t BTR;                                 /* 0x01C bit timing (writable in initialisation mode only) */
    uint32_t reserved0[88];                                /* 0x020 .. 0x17F */
    caekf_bxcan_tx_mailbox_t tx[CAEKF_BXCAN_TX_MAILBOXES]; /* 0x180, 0x190, 0x1A0 */
    caekf_bxcan_rx_mailbox_t rx[CAEKF_BXCAN_RX_FIFOS];     /* 0x1B0 (FIFO 0), 0x1C0 (FIFO 1) */
    uint32_t reserved1[12];                                /* 0x1D0 .. 0x1FF */
    volatile uint32_t FMR;                                 /* 0x200 filter master (FINIT, CAN2SB) */
    volatile uint32_t FM1R;  /* 0x204 filter mode: bit x = 1 identifier list, 0 identifier mask */
    uint32_t reserved2;      /* 0x208 */
    volatile uint32_t FS1R;  /* 0x20C filter scale: bit x = 1 single 32-bit, 0 dual 16-bit */
    uint32_t reserved3;      /* 0x210 */
    volatile uint32_t FFA1R; /* 0x214 filter FIFO assignment: bit x = FIFO of bank x */
    uint32_t reserved4;      /* 0x218 */
    volatile uint32_t FA1R;  /* 0x21C filter activation: bit x = 1 active */
    uint32_t reserved5[8];   /* 0x220 .. 0x23F */
    caekf_bxcan_filter_bank_t filter[CAEKF_BXCAN_FILTER_BANKS]; /* 0x240 .. 0x31F */
} caekf_bxcan_regs_t;

/* Layout checks (C99 has no _Static_assert: a negative array size stops the compilation). */
#define CAEKF_BXCAN_OFFSET_CHECK(member, offset) \
    typedef char caekf_bxcan_offset_check_##offset[(offsetof(caekf_bxcan_regs_t, member) == (offset)) ? 1 : -1]
CAEKF_BXCAN_OFFSET_CHECK(MCR, 0x000);
CAEKF_BXCAN_OFFSET_CHECK(MSR, 0x004);
CAEKF_BXCAN_OFFSET_CHECK(TSR, 0x008);
CAEKF_BXCAN_OFFSET_CHECK(RF0R, 0x00C);
CAEKF_BXCAN_OFFSET_CHECK(RF1R, 0x010);
CAEKF_BXCAN_OFFSET_CHECK(IER, 0x014);
CAEKF_BXCAN_OFFSET_CHECK(ESR, 0x018);
CAEKF_BXCAN_OFFSET_CHECK(BTR, 0x01C);
CAEKF_BXCAN_OFFSET_CHECK(tx[0].TIR, 0x180);
CAEKF_BXCAN_OFFSET_CHECK(tx[0].TDTR, 0x184);
CAEKF_BXCAN_OFFSET_CHECK(tx[0].TDLR, 0x188);
CAEKF_BXCAN_OFFSET_CHECK(tx[0].TDHR, 0x18C);
CAEKF_BXCAN_OFFSET_CHECK(tx[1].TIR, 0x190);
CAEKF_BXCAN_OFFSET_CHECK(tx[2].TIR, 0x1A0);
CAEKF_BXCAN_OFFSET_CHECK(tx[2].TDHR, 0x1AC);
CAEKF_BXCAN_OFFSET_CHECK(rx[0].RIR, 0x1B0);
CAEKF_BXCAN_OFFSET_CHECK(rx[0].RDTR, 0x1B4);
CAEKF_BXCAN_OFFSET_CHECK(rx[0].RDLR, 0x1B8);
CAEKF_BXCAN_OFFSET_CHECK(rx[0].RDHR, 0x1BC);
CAEKF_BXCAN_OFFSET_CHECK(rx[1].RIR, 0x1C0);
CAEKF_BXCAN_OFFSET_CHECK(FMR, 0x200);
CAEKF_BXCAN_OFFSET_CHECK(FM1R, 0x204);
CAEKF_BXCAN_OFFSET_CHECK(FS1R, 0x20C);
CAEKF_BXCAN_OFFSET_CHECK(FFA1R, 0x214);
CAEKF_BXCAN_OFFSET_CHECK(FA1R, 0x21C);
CAEKF_BXCAN_OFFSET_CHECK(filter[0].FR1, 0x240);
CAEKF_BXCAN_OFFSET_CHECK(filter[0].FR2, 0x244);
CAEKF_BXCAN_OFFSET_CHECK(filter[1].FR1, 0x248);
CAEKF_BXCAN_OFFSET_CHECK(filter[27].FR2, 0x31C);
typedef char caekf_bxcan_size_check[(sizeof(caekf_bxcan_regs_t) == 0x320u) ? 1 : -1];
#undef CAEKF_BXCAN_OFFSET_CHECK

/* ---- MCR ---- reset 0x0001_0002 (SLEEP, DBF) */
#define CAEKF_BXCAN_MCR_INRQ (1u << 0)   /* initialisation request */
#define CAEKF_BXCAN_MCR_SLEEP (1u << 1)  /* sleep mode request */
#define CAEKF_BXCAN_MCR_TXFP (1u << 2)   /* TX priority: 1 chronological, 0 by identifier */
#define CAEKF_BXCAN_MCR_RFLM (1u << 3)   /* RX FIFO locked: 1 a new message is discarded when full */
#define CAEKF_BXCAN_MCR_NART (1u << 4)   /* no automatic retransmission */
#define CAEKF_BXCAN_MCR_AWUM (1u << 5)   /* automatic wake-up */
#define CAEKF_BXCAN_MCR_ABOM (1u << 6)   /* automatic bus-off management (recovery) */
#define CAEKF_BXCAN_MCR_TTCM (1u << 7)   /* time-triggered communication */
#define CAEKF_BXCAN_MCR_RESET (1u << 15) /* software master reset */
#define CAEKF_BXCAN_MCR_DBF (1u << 16)   /* CAN frozen while the core is halted by a debugger */
#define CAEKF_BXCAN_MCR_RESET_VALUE 0x00010002u

/* ---- MSR ---- reset 0x0000_0C02 */
#define CAEKF_BXCAN_MSR_INAK (1u << 0)  /* initialisation acknowledge */
#define CAEKF_BXCAN_MSR_SLAK (1u << 1)  /* sleep acknowledge */
#define CAEKF_BXCAN_MSR_ERRI (1u << 2)  /* error interrupt (rc_w1) */
#define CAEKF_BXCAN_MSR_WKUI (1u << 3)  /* wake-up interrupt (rc_w1) */
#define CAEKF_BXCAN_MSR_SLAKI (1u << 4) /* sleep acknowledge interrupt (rc_w1) */
#define CAEKF_BXCAN_MSR_TXM (1u << 8)   /* transmit mode */
#define CAEKF_BXCAN_MSR_RXM (1u << 9)   /* receive mode */
#define CAEKF_BXCAN_MSR_SAMP (1u << 10) /* last sample point */
#define CAEKF_BXCAN_MSR_RX (1u << 11)   /* CAN RX pin */
#define CAEKF_BXCAN_MSR_RESET_VALUE 0x00000C02u

/* ---- TSR ---- reset 0x1C00_0000 (all three mailboxes empty). Mailbox m (0..2): status bits at
 * 8*m: RQCP (request completed, rc_w1: writing 1 also clears TXOK, ALST, TERR), TXOK, ALST, TERR;
 * ABRQ at 8*m+7; TME (mailbox empty) at 26+m; LOW at 29+m. */
#define CAEKF_BXCAN_TSR_RQCP(m) (1u << (8u * (m)))
#define CAEKF_BXCAN_TSR_TXOK(m) (1u << (8u * (m) + 1u))
#define CAEKF_BXCAN_TSR_ALST(m) (1u << (8u * (m) + 2u))
#define CAEKF_BXCAN_TSR_TERR(m) (1u << (8u * (m) + 3u))
#define CAEKF_BXCAN_TSR_ABRQ(m) (1u << (8u * (m) + 7u))
#define CAEKF_BXCAN_TSR_CODE_SHIFT 24u
#define CAEKF_BXCAN_TSR_CODE_MASK (3u << 24)
#define CAEKF_BXCAN_TSR_TME(m) (1u << (26u + (m)))
#define CAEKF_BXCAN_TSR_TME_ALL (7u << 26)
#define CAEKF_BXCAN_TSR_LOW(m) (1u << (29u + (m)))
#define CAEKF_BXCAN_TSR_RESET_VALUE 0x1C000000u

/* ---- RF0R / RF1R ---- */
#define CAEKF_BXCAN_RFR_FMP_MASK 3u    /* messages pending, 0..3 */
#define CAEKF_BXCAN_RFR_FULL (1u << 3) /* FIFO full (rc_w1) */
#define CAEKF_BXCAN_RFR_FOVR (1u << 4) /* FIFO overrun: a message was lost (rc_w1) */
#define CAEKF_BXCAN_RFR_RFOM (1u << 5) /* release output mailbox (set by software, cleared by hardware) */

/* ---- IER (the driver polls: it writes 0) ---- */
#define CAEKF_BXCAN_IER_TMEIE (1u << 0)
#define CAEKF_BXCAN_IER_FMPIE0 (1u << 1)
#define CAEKF_BXCAN_IER_FOVIE0 (1u << 3)
#define CAEKF_BXCAN_IER_BOFIE (1u << 10)
#define CAEKF_BXCAN_IER_ERRIE (1u << 15)

/* ---- ESR ---- */
#define CAEKF_BXCAN_ESR_EWGF (1u << 0) /* error warning (TEC or REC >= 96) */
#define CAEKF_BXCAN_ESR_EPVF (1u << 1) /* error passive (TEC or REC > 127) */
#define CAEKF_BXCAN_ESR_BOFF (1u << 2) /* bus-off (TEC > 255) */
#define CAEKF_BXCAN_ESR_LEC_SHIFT 4u   /* last error code, 3 bits */
#define CAEKF_BXCAN_ESR_LEC_MASK (7u << 4)
#define CAEKF_BXCAN_ESR_TEC_SHIFT 16u
#define CAEKF_BXCAN_ESR_REC_SHIFT 24u

/* ---- BTR ---- fields hold value - 1 */
#define CAEKF_BXCAN_BTR_BRP_SHIFT 0u    /* 10 bits: prescaler - 1 */
#define CAEKF_BXCAN_BTR_TS1_SHIFT 16u   /* 4 bits: time segment 1 - 1 */
#define CAEKF_BXCAN_BTR_TS2_SHIFT 20u   /* 3 bits: time segment 2 - 1 */
#define CAEKF_BXCAN_BTR_SJW_SHIFT 24u   /* 2 bits: resynchronisation jump width - 1 */
#define CAEKF_BXCAN_BTR_LBKM (1u << 30) /* loop back mode */
#define CAEKF_BXCAN_BTR_SILM (1u << 31) /* silent mode */

/* ---- TIxR / RIxR ---- */
#define CAEKF_BXCAN_IR_TXRQ (1u << 0) /* TIxR only: transmit request (cleared by hardware when empty) */
#define CAEKF_BXCAN_IR_RTR (1u << 1)
#define CAEKF_BXCAN_IR_IDE (1u << 2)
#define CAEKF_BXCAN_IR_EXID_SHIFT 3u  /* 29-bit identifier in bits 31:3 */
#define CAEKF_BXCAN_IR_STID_SHIFT 21u /* 11-bit identifier in bits 31:21 */

/* ---- TDTxR / RDTxR ---- */
#define CAEKF_BXCAN_DTR_DLC_MASK 0xFu
#define CAEKF_BXCAN_TDTR_TGT (1u << 8)
#define CAEKF_BXCAN_RDTR_FMI_SHIFT 8u
#define CAEKF_BXCAN_DTR_TIME_SHIFT 16u

/* ---- FMR ---- reset 0x2A1C_0E01 (FINIT, CAN2SB = 14) */
#define CAEKF_BXCAN_FMR_FINIT (1u << 0)
#define CAEKF_BXCAN_FMR_CAN2SB_SHIFT 8u
#define CAEKF_BXCAN_FMR_CAN2SB_MASK (0x3Fu << 8)
#define CAEKF_BXCAN_FMR_RESET_VALUE 0x2A1C0E01u

/* 16-bit filter word (dual 16-bit scale): STID[10:0] in 15:5, RTR bit 4, IDE bit 3, EXID[17:15] 2:0.
 * In list mode FR1 holds filters n (15:0) and n+1 (31:16), FR2 n+2 and n+3; in mask mode FR1 holds
 * identifier (15:0) and mask (31:16) of filter n, FR2 those of filter n+1. */
#define CAEKF_BXCAN_F16_STID_SHIFT 5u
#define CAEKF_BXCAN_F16_RTR (1u << 4)
#define CAEKF_BXCAN_F16_IDE (1u << 3)

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_BXCAN_REGS_H */
