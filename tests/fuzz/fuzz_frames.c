/*
 * libFuzzer harness 4: the frame decoders on their own - every message layout of firmware/protocol decoded
 * from arbitrary payloads, and the E2E protection, without the app or the estimator.
 *
 * Input layout: records until the end, 10 bytes each (missing bytes read as 0):
 *   [message] [counter] [8 payload bytes]   message modulo CAEKF_MSG_COUNT
 *
 * Invariants (any violation aborts, i.e. is a finding):
 *   msg_info / msg_from_id: every message has an info row whose CAN id maps back to it.
 *   decode_*: OK or ERR_VALUE only (ERR_MSG never for the message's own layout); a decoded message
 *         re-encodes (OK or SATURATED) to a payload that decodes to the same fields, bit for bit.
 *   E2E: caekf_e2e_crc equals CRC-8/SAE-J1850 (caekf_crc8) over [data id low, data id high, bytes 1..7];
 *         a payload sealed by caekf_e2e_protect passes caekf_e2e_check on a fresh receiver, a second copy
 *         is a duplicate, a payload with byte 0 changed fails the CRC and leaves the receiver as it was.
 */
#include "fuzz_common.h"

#include "caekf/caekf_crc8.h"
#include "caekf/caekf_e2e.h"
#include "caekf/caekf_proto.h"

#define DLC CAEKF_CAN_DLC

/* decode -> encode -> decode of one fixed layout: the same fields, bit for bit (structs zeroed first, so
 * padding compares equal). */
#define ROUND_TRIP(type, dec, enc, payload)                                                              \
    do {                                                                                                 \
        type a_, b_;                                                                                     \
        uint8_t q_[DLC];                                                                                 \
        caekf_proto_status_t s_;                                                                         \
        memset(&a_, 0, sizeof a_);                                                                       \
        memset(&b_, 0, sizeof b_);                                                                       \
        s_ = dec((payload), &a_);                                                                        \
        FZ_CHECK(s_ == CAEKF_PROTO_OK || s_ == CAEKF_PROTO_ERR_VALUE, #dec ": OK or ERR_VALUE");         \
        if (s_ == CAEKF_PROTO_OK) {                                                                      \
            memset(q_, 0, sizeof q_);                                                                    \
            s_ = enc(&a_, q_);                                                                           \
            FZ_CHECK(s_ == CAEKF_PROTO_OK || s_ == CAEKF_PROTO_SATURATED, #enc " of a decoded message"); \
            FZ_CHECK(dec(q_, &b_) == CAEKF_PROTO_OK, #dec " of a re-encoded message");                   \
            FZ_CHECK(memcmp(&a_, &b_, sizeof a_) == 0, "decode(encode(decode(p))) == decode(p)");        \
        }                                                                                                \
    } while (0)

static void check_value(caekf_msg_t msg, const uint8_t p[DLC])
{
    uint16_t step = 0, step2 = 0;
    double v = 0.0, v2 = 0.0;
    uint8_t q[DLC];
    caekf_proto_status_t st = caekf_proto_decode_value(msg, p, &step, &v);
    FZ_CHECK(st == CAEKF_PROTO_OK || st == CAEKF_PROTO_ERR_VALUE, "decode_value: OK or ERR_VALUE");
    if (st != CAEKF_PROTO_OK) {
        return;
    }
    memset(q, 0, sizeof q);
    st = caekf_proto_encode_value(msg, step, v, q);
    FZ_CHECK(st == CAEKF_PROTO_OK || st == CAEKF_PROTO_SATURATED, "encode_value of a decoded value");
    FZ_CHECK(caekf_proto_decode_value(msg, q, &step2, &v2) == CAEKF_PROTO_OK, "decode_value of a re-encoded value");
    FZ_CHECK(step2 == step && memcmp(&v, &v2, sizeof v) == 0, "value round trip, bit for bit");
}

static void check_e2e(uint16_t data_id, uint8_t counter, const uint8_t p[DLC])
{
    uint8_t sealed[DLC], buf[2 + DLC - 1], crc = 0, ref = 0, lost = 0;
    caekf_e2e_rx_t rx, kept;
    memcpy(sealed, p, DLC);
    FZ_CHECK(caekf_e2e_crc(data_id, p, &crc) == CAEKF_E2E_OK, "e2e_crc");
    buf[0] = (uint8_t)(data_id & 0xFFu);
    buf[1] = (uint8_t)(data_id >> 8);
    memcpy(buf + 2, p + 1, DLC - 1u);
    FZ_CHECK(caekf_crc8(buf, sizeof buf, &ref) == 0, "crc8");
    FZ_CHECK(crc == ref, "e2e_crc is CRC-8/SAE-J1850 over the data id and bytes 1..7");
    FZ_CHECK(caekf_e2e_protect(data_id, counter, sealed) == CAEKF_E2E_OK, "e2e_protect");
    FZ_CHECK((sealed[1] & 0x0Fu) == (counter & 0x0Fu) && (sealed[1] & 0xF0u) == (p[1] & 0xF0u) &&
                 memcmp(sealed + 2, p + 2, DLC - 2u) == 0,
             "protect writes only the counter and the CRC");
    FZ_CHECK(caekf_e2e_rx_init(&rx) == CAEKF_E2E_OK, "rx_init");
    FZ_CHECK(caekf_e2e_check(&rx, data_id, 1, sealed, DLC, &lost) == CAEKF_E2E_OK, "a sealed frame passes");
    FZ_CHECK(lost == 0, "no frame lost on a fresh receiver");
    FZ_CHECK(caekf_e2e_check(&rx, data_id, 1, sealed, DLC, NULL) == CAEKF_E2E_ERR_DUPLICATE, "a copy is a duplicate");
    sealed[0] ^= (uint8_t)(1u + (counter >> 4)); /* never 0: the CRC byte changes */
    kept = rx;
    FZ_CHECK(caekf_e2e_check(&rx, data_id, 15, sealed, DLC, NULL) == CAEKF_E2E_ERR_CRC, "a bad CRC fails");
    FZ_CHECK(memcmp(&kept, &rx, sizeof rx) == 0, "a CRC error leaves the receiver as it was");
    FZ_CHECK(caekf_e2e_check(&rx, data_id, 1, sealed, (uint8_t)(DLC - 1u), NULL) == CAEKF_E2E_ERR_DLC,
             "a short frame fails its DLC");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    size_t off = 0;
    while (off < size) {
        uint8_t rec[2 + DLC];
        const uint8_t *p = rec + 2;
        const caekf_msg_info_t *info = NULL;
        caekf_msg_t msg, back;
        size_t i;
        for (i = 0; i < sizeof rec; ++i) {
            rec[i] = off + i < size ? data[off + i] : 0u;
        }
        off += sizeof rec;
        msg = (caekf_msg_t)(rec[0] % (unsigned)CAEKF_MSG_COUNT);
        FZ_CHECK(caekf_proto_msg_info(msg, &info) == CAEKF_PROTO_OK && info != NULL, "msg_info");
        FZ_CHECK(caekf_proto_msg_from_id(info->can_id, &back) == CAEKF_PROTO_OK && back == msg, "msg_from_id");
        switch ((caekf_layout_t)info->layout) {
        case CAEKF_LAYOUT_RESET:
            ROUND_TRIP(caekf_msg_reset_t, caekf_proto_decode_reset, caekf_proto_encode_reset, p);
            break;
        case CAEKF_LAYOUT_PARAM:
            ROUND_TRIP(caekf_msg_param_t, caekf_proto_decode_param, caekf_proto_encode_param, p);
            break;
        case CAEKF_LAYOUT_STATUS_REQ:
            ROUND_TRIP(caekf_msg_status_req_t, caekf_proto_decode_status_req, caekf_proto_encode_status_req, p);
            break;
        case CAEKF_LAYOUT_ACK: ROUND_TRIP(caekf_msg_ack_t, caekf_proto_decode_ack, caekf_proto_encode_ack, p); break;
        case CAEKF_LAYOUT_HEALTH:
            ROUND_TRIP(caekf_msg_health_t, caekf_proto_decode_health, caekf_proto_encode_health, p);
            break;
        case CAEKF_LAYOUT_STEP:
            ROUND_TRIP(caekf_msg_step_t, caekf_proto_decode_step, caekf_proto_encode_step, p);
            break;
        case CAEKF_LAYOUT_YP: ROUND_TRIP(caekf_msg_yp_t, caekf_proto_decode_yp, caekf_proto_encode_yp, p); break;
        case CAEKF_LAYOUT_PROD:
            ROUND_TRIP(caekf_msg_prod_t, caekf_proto_decode_prod, caekf_proto_encode_prod, p);
            break;
        case CAEKF_LAYOUT_PAGE:
            ROUND_TRIP(caekf_msg_page_t, caekf_proto_decode_page, caekf_proto_encode_page, p);
            break;
        case CAEKF_LAYOUT_INT36:
        case CAEKF_LAYOUT_FLOAT32: check_value(msg, p); break;
        case CAEKF_LAYOUT_FD_IN:
        case CAEKF_LAYOUT_FD_OUT:
            /* 64-byte CAN FD payloads with a CRC-16: this harness feeds classic 8-byte records (the FD
             * codec is checked against cantools in test_proto_codec and over vcan in the HIL). */
            continue;
        default: FZ_CHECK(0, "a layout this harness does not know");
        }
        check_e2e(info->data_id, rec[1], p);
    }
    return 0;
}
