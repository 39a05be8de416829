/*
 * E2E protection in the style of AUTOSAR profile 1, for classic CAN frames of 8 bytes:
 *   byte 0      CRC-8/SAE-J1850 over [data_id low byte, data_id high byte, payload bytes 1..7]
 *   bits 8..11  4-bit alive counter, +1 per frame of that message, wrapping 15 -> 0
 * Deviations from profile 1, on purpose: the counter uses all 16 values (no invalid 15), and both
 * data ID bytes always enter the CRC (profile 1's DataIDMode "both").
 *
 * CAN FD frames (longer payloads, the CAN FD profile) in the style of AUTOSAR profile 5:
 *   bytes 0..1  CRC-16/CCITT-FALSE (little-endian) over [data_id low, data_id high, payload bytes 2..len-1]
 *   bits 16..19 the same 4-bit alive counter
 *
 * The receiver keeps one caekf_e2e_rx_t per message. The first frame after init (or after
 * caekf_e2e_rx_init, e.g. when the sender went silent) is accepted with any counter.
 */
#ifndef CAEKF_E2E_H
#define CAEKF_E2E_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define CAEKF_E2E_DLC 8u
#define CAEKF_E2E_COUNTER_MASK 0x0Fu

typedef enum {
    CAEKF_E2E_OK = 0,
    CAEKF_E2E_ERR_NULL = -1,
    CAEKF_E2E_ERR_DLC = -2,       /* DLC is not the message's length (8 for classic frames) */
    CAEKF_E2E_ERR_CRC = -3,       /* CRC mismatch: payload or data ID corrupted */
    CAEKF_E2E_ERR_DUPLICATE = -4, /* same counter as the last accepted frame */
    CAEKF_E2E_ERR_JUMP = -5       /* counter advanced by more than max_delta: receiver re-synced to it */
} caekf_e2e_status_t;

typedef struct {
    uint8_t last_counter; /* counter of the last accepted (or re-synced) frame */
    uint8_t synced;       /* 0 until the first frame: then any counter is accepted */
} caekf_e2e_rx_t;

/* Forgets the counter history: the next frame is accepted with any counter. */
caekf_e2e_status_t caekf_e2e_rx_init(caekf_e2e_rx_t *rx);

/* Computes the CRC of a payload (byte 0 ignored). */
caekf_e2e_status_t caekf_e2e_crc(uint16_t data_id, const uint8_t payload[CAEKF_E2E_DLC], uint8_t *crc_out);

/* Writes `counter` (low 4 bits) into bits 8..11, keeping bits 12..15, then the CRC into byte 0. */
caekf_e2e_status_t caekf_e2e_protect(uint16_t data_id, uint8_t counter, uint8_t payload[CAEKF_E2E_DLC]);

/* Checks one received frame, in this order: DLC, CRC, counter. max_delta (clamped to 1..15) is the
 * largest accepted counter step; 1 accepts only consecutive frames. On CAEKF_E2E_OK, *lost (may be
 * NULL) receives the number of frames skipped (delta - 1). CRC and DLC errors and duplicates leave
 * the state unchanged; a jump re-syncs to the new counter so the next consecutive frame passes. */
caekf_e2e_status_t caekf_e2e_check(caekf_e2e_rx_t *rx, uint16_t data_id, uint8_t max_delta, const uint8_t *payload,
                                   uint8_t dlc, uint8_t *lost);

/* CAN FD frames of `len` bytes (3..64): CRC-16 of a payload (bytes 0..1 ignored). */
caekf_e2e_status_t caekf_e2e_crc16(uint16_t data_id, const uint8_t *payload, uint8_t len, uint16_t *crc_out);
/* Writes `counter` (low 4 bits) into bits 16..19, keeping bits 20..23, then the CRC-16 into bytes 0..1. */
caekf_e2e_status_t caekf_e2e_protect_fd(uint16_t data_id, uint8_t counter, uint8_t *payload, uint8_t len);
/* As caekf_e2e_check, for a message of `len` bytes: a frame of another length is CAEKF_E2E_ERR_DLC. */
caekf_e2e_status_t caekf_e2e_check_fd(caekf_e2e_rx_t *rx, uint16_t data_id, uint8_t max_delta, const uint8_t *payload,
                                      uint8_t dlc, uint8_t len, uint8_t *lost);

#ifdef __cplusplus
}
#endif

#endif /* CAEKF_E2E_H */
