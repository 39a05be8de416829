/* E2E profile-1-style protect and check. See caekf_e2e.h for the frame layout. */
#include "caekf/caekf_e2e.h"

#include <stddef.h>

#include "caekf/caekf_crc16.h"
#include "caekf/caekf_crc8.h"

#define COUNTER_BYTE 1u
#define FD_COUNTER_BYTE 2u
#define FD_MIN_LEN 3u
#define FD_MAX_LEN 64u
#define MAX_DELTA_LIMIT 15u

caekf_e2e_status_t caekf_e2e_rx_init(caekf_e2e_rx_t *rx)
{
    if (rx == NULL) {
        return CAEKF_E2E_ERR_NULL;
    }
    rx->last_counter = 0;
    rx->synced = 0;
    return CAEKF_E2E_OK;
}

caekf_e2e_status_t caekf_e2e_crc(uint16_t data_id, const uint8_t payload[CAEKF_E2E_DLC], uint8_t *crc_out)
{
    /* The data ID is never sent: it enters the CRC so a frame of one message cannot pass as another. */
    uint8_t id_bytes[2];
    uint8_t crc;
    if (payload == NULL || crc_out == NULL) {
        return CAEKF_E2E_ERR_NULL;
    }
    id_bytes[0] = (uint8_t)(data_id & 0xFFu);
    id_bytes[1] = (uint8_t)(data_id >> 8);
    crc = caekf_crc8_update(CAEKF_CRC8_INIT, id_bytes, sizeof id_bytes);
    crc = caekf_crc8_update(crc, &payload[1], CAEKF_E2E_DLC - 1u);
    *crc_out = (uint8_t)(crc ^ CAEKF_CRC8_XOROUT);
    return CAEKF_E2E_OK;
}

caekf_e2e_status_t caekf_e2e_protect(uint16_t data_id, uint8_t counter, uint8_t payload[CAEKF_E2E_DLC])
{
    if (payload == NULL) {
        return CAEKF_E2E_ERR_NULL;
    }
    payload[COUNTER_BYTE] = (uint8_t)((payload[COUNTER_BYTE] & 0xF0u) | (counter & CAEKF_E2E_COUNTER_MASK));
    return caekf_e2e_crc(data_id, payload, &payload[0]);
}

/* The alive-counter part of a check, after the length and CRC passed. */
static caekf_e2e_status_t check_counter(caekf_e2e_rx_t *rx, uint8_t counter, uint8_t max_delta, uint8_t *lost)
{
    uint8_t delta;
    if (max_delta < 1u) {
        max_delta = 1u;
    }
    if (max_delta > MAX_DELTA_LIMIT) {
        max_delta = MAX_DELTA_LIMIT;
    }
    if (!rx->synced) {
        rx->synced = 1;
        rx->last_counter = counter;
        if (lost != NULL) {
            *lost = 0;
        }
        return CAEKF_E2E_OK;
    }
    delta = (uint8_t)((counter - rx->last_counter) & CAEKF_E2E_COUNTER_MASK);
    if (delta == 0u) {
        return CAEKF_E2E_ERR_DUPLICATE;
    }
    rx->last_counter = counter;
    if (delta > max_delta) {
        return CAEKF_E2E_ERR_JUMP;
    }
    if (lost != NULL) {
        *lost = (uint8_t)(delta - 1u);
    }
    return CAEKF_E2E_OK;
}

caekf_e2e_status_t caekf_e2e_check(caekf_e2e_rx_t *rx, uint16_t data_id, uint8_t max_delta, const uint8_t *payload,
                                   uint8_t dlc, uint8_t *lost)
{
    uint8_t crc;
    if (rx == NULL || payload == NULL) {
        return CAEKF_E2E_ERR_NULL;
    }
    if (dlc != CAEKF_E2E_DLC) {
        return CAEKF_E2E_ERR_DLC;
    }
    (void)caekf_e2e_crc(data_id, payload, &crc);
    if (crc != payload[0]) {
        return CAEKF_E2E_ERR_CRC;
    }
    return check_counter(rx, (uint8_t)(payload[COUNTER_BYTE] & CAEKF_E2E_COUNTER_MASK), max_delta, lost);
}

caekf_e2e_status_t caekf_e2e_crc16(uint16_t data_id, const uint8_t *payload, uint8_t len, uint16_t *crc_out)
{
    uint8_t id_bytes[2];
    uint16_t crc;
    if (payload == NULL || crc_out == NULL) {
        return CAEKF_E2E_ERR_NULL;
    }
    if (len < FD_MIN_LEN || len > FD_MAX_LEN) {
        return CAEKF_E2E_ERR_DLC;
    }
    id_bytes[0] = (uint8_t)(data_id & 0xFFu);
    id_bytes[1] = (uint8_t)(data_id >> 8);
    crc = caekf_crc16_update(CAEKF_CRC16_INIT, id_bytes, sizeof id_bytes);
    *crc_out = caekf_crc16_update(crc, &payload[2], (size_t)len - 2u);
    return CAEKF_E2E_OK;
}

caekf_e2e_status_t caekf_e2e_protect_fd(uint16_t data_id, uint8_t counter, uint8_t *payload, uint8_t len)
{
    uint16_t crc = 0u;
    caekf_e2e_status_t st;
    if (payload == NULL) {
        return CAEKF_E2E_ERR_NULL;
    }
    if (len < FD_MIN_LEN || len > FD_MAX_LEN) {
        return CAEKF_E2E_ERR_DLC;
    }
    payload[FD_COUNTER_BYTE] = (uint8_t)((payload[FD_COUNTER_BYTE] & 0xF0u) | (counter & CAEKF_E2E_COUNTER_MASK));
    st = caekf_e2e_crc16(data_id, payload, len, &crc);
    payload[0] = (uint8_t)(crc & 0xFFu);
    payload[1] = (uint8_t)(crc >> 8);
    return st;
}

caekf_e2e_status_t caekf_e2e_check_fd(caekf_e2e_rx_t *rx, uint16_t data_id, uint8_t max_delta, const uint8_t *payload,
                                      uint8_t dlc, uint8_t len, uint8_t *lost)
{
    uint16_t crc = 0u;
    if (rx == NULL || payload == NULL) {
        return CAEKF_E2E_ERR_NULL;
    }
    if (dlc != len || caekf_e2e_crc16(data_id, payload, len, &crc) != CAEKF_E2E_OK) {
        return CAEKF_E2E_ERR_DLC;
    }
    if (payload[0] != (uint8_t)(crc & 0xFFu) || payload[1] != (uint8_t)(crc >> 8)) {
        return CAEKF_E2E_ERR_CRC;
    }
    return check_counter(rx, (uint8_t)(payload[FD_COUNTER_BYTE] & CAEKF_E2E_COUNTER_MASK), max_delta, lost);
}
