/*
 * caekf_proto_dump: a line-oriented front end to the C codec, so tests/protocol can compare it with
 * cantools' reading of caekf.dbc. One command per input line, one answer line per command:
 *   info                               -> one line per message "NAME CAN_ID DATA_ID LAYOUT DIR LEN LSB", then "end"
 *   names param|counter|experiment     -> one line per name, then "end"
 *   enc_value MSG STEP VALUE           -> "STATUS HEX"     (VALUE as C99 hex float, "nan", "inf")
 *   dec_value MSG HEX                  -> "STATUS STEP VALUE" (VALUE printed with %a)
 *   enc_step STEP FLAGS ITERS STATUS   -> "STATUS HEX";     dec_step HEX -> "STATUS STEP FLAGS ITERS STATUS"
 *   enc_reset EXP N TOKEN              -> "STATUS HEX";     dec_reset HEX -> "STATUS EXP N TOKEN"
 *   enc_param ID EXP10 MANT            -> "STATUS HEX";     dec_param HEX -> "STATUS ID EXP10 MANT"
 *   param_value ID EXP10 MANT          -> "STATUS VALUE"
 *   enc_status_req TOKEN               -> "STATUS HEX";     dec_status_req HEX -> "STATUS TOKEN"
 *   enc_ack TOKEN ST BAD EXP N STATE   -> "STATUS HEX";     dec_ack HEX -> "STATUS TOKEN ST BAD EXP N STATE"
 *   enc_health PAGE A B                -> "STATUS HEX";     dec_health HEX -> "STATUS PAGE A B"
 *   seal MSG COUNTER HEX               -> "STATUS HEX" (ID/DLC set, counter and CRC written)
 *   crc HEX                            -> "0 CRC" (CRC-8/SAE-J1850 of the bytes)
 *   crc16 HEX                          -> "0 CRC" (CRC-16/CCITT-FALSE of the bytes)
 *   enc_fd_in STEP U Y1 Y4             -> "STATUS HEX20";   dec_fd_in HEX20 -> "STATUS STEP U Y1 Y4" (%a)
 *   enc_fd_out STEP X0..X8 PN PGG FLAGS ITERS STATUS -> "STATUS HEX64"
 *   dec_fd_out HEX64                   -> "STATUS STEP X0..X8 PN PGG FLAGS ITERS STATUS" (values %a)
 *   seal_fd MSG COUNTER HEX            -> "STATUS HEX" (the message's length: CRC-16 and counter written)
 * MSG is a message name as in the DBC. HEX is 16 hex digits (8 bytes) unless stated otherwise.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "caekf/caekf_crc16.h"
#include "caekf/caekf_crc8.h"
#include "caekf/caekf_proto.h"

#define LINE_MAX_LEN 512
#define MAX_HEX_BYTES 64

static int parse_hex(const char *s, uint8_t *out, size_t max, size_t *n)
{
    size_t len = strlen(s), i;
    if (len % 2u != 0u || len / 2u > max) {
        return -1;
    }
    for (i = 0; i < len / 2u; i++) {
        unsigned v;
        if (sscanf(s + 2u * i, "%2x", &v) != 1) {
            return -1;
        }
        out[i] = (uint8_t)v;
    }
    *n = len / 2u;
    return 0;
}

static void print_hex_n(int st, const uint8_t *d, unsigned n)
{
    unsigned i;
    printf("%d ", st);
    for (i = 0; i < n; i++) {
        printf("%02x", d[i]);
    }
    printf("\n");
}

static void print_hex(int st, const uint8_t *d) { print_hex_n(st, d, 8u); }

static int msg_by_name(const char *name, caekf_msg_t *msg)
{
    unsigned i;
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        const caekf_msg_info_t *info;
        if (caekf_proto_msg_info((caekf_msg_t)i, &info) == CAEKF_PROTO_OK && strcmp(info->name, name) == 0) {
            *msg = (caekf_msg_t)i;
            return 0;
        }
    }
    return -1;
}

static int payload_arg(const char *s, uint8_t d[8])
{
    size_t n;
    return (parse_hex(s, d, 8, &n) == 0 && n == 8u) ? 0 : -1;
}

static void cmd_info(void)
{
    unsigned i;
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        const caekf_msg_info_t *info;
        (void)caekf_proto_msg_info((caekf_msg_t)i, &info);
        printf("%s %u %u %u %u %u %.17g\n", info->name, info->can_id, info->data_id, info->layout, info->dir, info->len,
               info->lsb);
    }
    printf("end\n");
}

static void cmd_names(const char *kind)
{
    unsigned i;
    const char *name;
    for (i = 0; i < 256u; i++) {
        caekf_proto_status_t st;
        if (strcmp(kind, "counter") == 0) {
            st = caekf_proto_counter_name(i, &name);
        } else {
            st = CAEKF_PROTO_ERR_RANGE;
        }
        if (st != CAEKF_PROTO_OK) {
            break;
        }
        printf("%s\n", name);
    }
    printf("end\n");
}

static int run(char *line)
{
    char a[16][160];
    uint8_t d[8];
    caekf_msg_t msg;
    int n = 0;
    int used = 0;
    memset(d, 0, sizeof d);
    while (n < 16 && sscanf(line + used, "%159s", a[n]) == 1) { /* whitespace-separated words */
        const char *w = strstr(line + used, a[n]);
        used = (int)(w - line) + (int)strlen(a[n]);
        n++;
    }
    if (n < 1) {
        return 0;
    }
    if (strcmp(a[0], "info") == 0) {
        cmd_info();
    } else if (strcmp(a[0], "names") == 0 && n == 2) {
        cmd_names(a[1]);
    } else if (strcmp(a[0], "enc_value") == 0 && n == 4 && msg_by_name(a[1], &msg) == 0) {
        int st = caekf_proto_encode_value(msg, (uint16_t)strtoul(a[2], NULL, 0), strtod(a[3], NULL), d);
        print_hex(st, d);
    } else if (strcmp(a[0], "dec_value") == 0 && n == 3 && msg_by_name(a[1], &msg) == 0 && payload_arg(a[2], d) == 0) {
        uint16_t step = 0;
        double v = 0.0;
        int st = caekf_proto_decode_value(msg, d, &step, &v);
        printf("%d %u %a\n", st, step, v);
    } else if (strcmp(a[0], "enc_step") == 0 && n == 5) {
        caekf_msg_step_t m;
        m.step = (uint16_t)strtoul(a[1], NULL, 0);
        m.flags = (uint16_t)strtoul(a[2], NULL, 0);
        m.newton_iters = (uint8_t)strtoul(a[3], NULL, 0);
        m.step_status = (int8_t)strtol(a[4], NULL, 0);
        print_hex(caekf_proto_encode_step(&m, d), d);
    } else if (strcmp(a[0], "dec_step") == 0 && n == 2 && payload_arg(a[1], d) == 0) {
        caekf_msg_step_t m;
        int st = caekf_proto_decode_step(d, &m);
        printf("%d %u %u %u %d\n", st, m.step, m.flags, m.newton_iters, m.step_status);
    } else if (strcmp(a[0], "enc_yp") == 0 && n == 4) {
        caekf_msg_yp_t m;
        m.step = (uint8_t)strtoul(a[1], NULL, 0);
        m.y1 = strtod(a[2], NULL);
        m.y4 = strtod(a[3], NULL);
        print_hex(caekf_proto_encode_yp(&m, d), d);
    } else if (strcmp(a[0], "dec_yp") == 0 && n == 2 && payload_arg(a[1], d) == 0) {
        caekf_msg_yp_t m;
        int st = caekf_proto_decode_yp(d, &m);
        printf("%d %u %a %a\n", st, m.step, m.y1, m.y4);
    } else if (strcmp(a[0], "enc_prod") == 0 && n == 4) {
        caekf_msg_prod_t m;
        m.step = (uint8_t)strtoul(a[1], NULL, 0);
        m.flags = (uint16_t)strtoul(a[2], NULL, 0);
        m.gamma = strtod(a[3], NULL);
        print_hex(caekf_proto_encode_prod(&m, d), d);
    } else if (strcmp(a[0], "dec_prod") == 0 && n == 2 && payload_arg(a[1], d) == 0) {
        caekf_msg_prod_t m;
        int st = caekf_proto_decode_prod(d, &m);
        printf("%d %u %u %a\n", st, m.step, m.flags, m.gamma);
    } else if (strcmp(a[0], "enc_page") == 0 && n == 7) {
        caekf_msg_page_t m;
        m.page = (uint8_t)strtoul(a[1], NULL, 0);
        m.step = (uint16_t)strtoul(a[2], NULL, 0);
        m.value = strtod(a[3], NULL);
        m.info.step = m.step;
        m.info.flags = (uint16_t)strtoul(a[4], NULL, 0);
        m.info.newton_iters = (uint8_t)strtoul(a[5], NULL, 0);
        m.info.step_status = (int8_t)strtol(a[6], NULL, 0);
        print_hex(caekf_proto_encode_page(&m, d), d);
    } else if (strcmp(a[0], "dec_page") == 0 && n == 2 && payload_arg(a[1], d) == 0) {
        caekf_msg_page_t m;
        int st = caekf_proto_decode_page(d, &m);
        printf("%d %u %u %a %u %u %d\n", st, m.page, m.step, m.value, m.info.flags, m.info.newton_iters,
               m.info.step_status);
    } else if (strcmp(a[0], "enc_reset") == 0 && n == 3) {
        caekf_msg_reset_t m;
        m.n_params = (uint8_t)strtoul(a[1], NULL, 0);
        m.token = (uint8_t)strtoul(a[2], NULL, 0);
        print_hex(caekf_proto_encode_reset(&m, d), d);
    } else if (strcmp(a[0], "dec_reset") == 0 && n == 2 && payload_arg(a[1], d) == 0) {
        caekf_msg_reset_t m;
        int st = caekf_proto_decode_reset(d, &m);
        printf("%d %u %u\n", st, m.n_params, m.token);
    } else if ((strcmp(a[0], "enc_param") == 0 || strcmp(a[0], "param_value") == 0) && n == 4) {
        caekf_msg_param_t m;
        m.param_id = (uint8_t)strtoul(a[1], NULL, 0);
        m.param_exp10 = (int8_t)strtol(a[2], NULL, 0);
        m.param_mantissa = strtoll(a[3], NULL, 0);
        if (a[0][0] == 'e') {
            print_hex(caekf_proto_encode_param(&m, d), d);
        } else {
            double v = 0.0;
            int st = caekf_proto_param_value(&m, &v);
            printf("%d %a\n", st, v);
        }
    } else if (strcmp(a[0], "dec_param") == 0 && n == 2 && payload_arg(a[1], d) == 0) {
        caekf_msg_param_t m;
        int st = caekf_proto_decode_param(d, &m);
        printf("%d %u %d %lld\n", st, m.param_id, m.param_exp10, (long long)m.param_mantissa);
    } else if (strcmp(a[0], "enc_status_req") == 0 && n == 2) {
        caekf_msg_status_req_t m;
        m.token = (uint8_t)strtoul(a[1], NULL, 0);
        print_hex(caekf_proto_encode_status_req(&m, d), d);
    } else if (strcmp(a[0], "dec_status_req") == 0 && n == 2 && payload_arg(a[1], d) == 0) {
        caekf_msg_status_req_t m;
        int st = caekf_proto_decode_status_req(d, &m);
        printf("%d %u\n", st, m.token);
    } else if (strcmp(a[0], "enc_ack") == 0 && n == 6) {
        caekf_msg_ack_t m;
        m.token = (uint8_t)strtoul(a[1], NULL, 0);
        m.ack_status = (int8_t)strtol(a[2], NULL, 0);
        m.bad_param = (uint8_t)strtoul(a[3], NULL, 0);
        m.n_params_rx = (uint8_t)strtoul(a[4], NULL, 0);
        m.state = (uint8_t)strtoul(a[5], NULL, 0);
        print_hex(caekf_proto_encode_ack(&m, d), d);
    } else if (strcmp(a[0], "dec_ack") == 0 && n == 2 && payload_arg(a[1], d) == 0) {
        caekf_msg_ack_t m;
        int st = caekf_proto_decode_ack(d, &m);
        printf("%d %u %d %u %u %u\n", st, m.token, m.ack_status, m.bad_param, m.n_params_rx, m.state);
    } else if (strcmp(a[0], "enc_health") == 0 && n == 4) {
        caekf_msg_health_t m;
        m.page = (uint8_t)strtoul(a[1], NULL, 0);
        m.counter_a = (uint32_t)strtoul(a[2], NULL, 0);
        m.counter_b = (uint32_t)strtoul(a[3], NULL, 0);
        print_hex(caekf_proto_encode_health(&m, d), d);
    } else if (strcmp(a[0], "dec_health") == 0 && n == 2 && payload_arg(a[1], d) == 0) {
        caekf_msg_health_t m;
        int st;
        memset(&m, 0, sizeof m);
        st = caekf_proto_decode_health(d, &m);
        printf("%d %u %lu %lu\n", st, m.page, (unsigned long)m.counter_a, (unsigned long)m.counter_b);
    } else if (strcmp(a[0], "seal") == 0 && n == 4 && msg_by_name(a[1], &msg) == 0) {
        caekf_can_frame_t f;
        int st;
        if (payload_arg(a[3], f.data) != 0) {
            return -1;
        }
        st = caekf_proto_seal(msg, (uint8_t)strtoul(a[2], NULL, 0), &f);
        print_hex(st, f.data);
    } else if (strcmp(a[0], "crc") == 0 && n == 2) {
        uint8_t buf[MAX_HEX_BYTES];
        size_t len;
        uint8_t crc = 0;
        if (parse_hex(a[1], buf, sizeof buf, &len) != 0) {
            return -1;
        }
        (void)caekf_crc8(buf, len, &crc);
        printf("0 %02x\n", crc);
    } else if (strcmp(a[0], "crc16") == 0 && n == 2) {
        uint8_t buf[MAX_HEX_BYTES];
        size_t len;
        if (parse_hex(a[1], buf, sizeof buf, &len) != 0) {
            return -1;
        }
        printf("0 %04x\n", caekf_crc16_update(CAEKF_CRC16_INIT, buf, len));
    } else if (strcmp(a[0], "enc_fd_in") == 0 && n == 5) {
        caekf_msg_fd_in_t m;
        uint8_t fd[CAEKF_CAN_FD_MAX_LEN];
        memset(fd, 0, sizeof fd);
        m.step = (uint16_t)strtoul(a[1], NULL, 0);
        m.u = strtod(a[2], NULL);
        m.y1 = strtod(a[3], NULL);
        m.y4 = strtod(a[4], NULL);
        print_hex_n(caekf_proto_encode_fd_in(&m, fd), fd, CAEKF_FD_IN_LEN);
    } else if (strcmp(a[0], "dec_fd_in") == 0 && n == 2) {
        caekf_msg_fd_in_t m;
        uint8_t fd[CAEKF_CAN_FD_MAX_LEN];
        size_t len;
        int st;
        memset(&m, 0, sizeof m);
        if (parse_hex(a[1], fd, sizeof fd, &len) != 0 || len != CAEKF_FD_IN_LEN) {
            return -1;
        }
        st = caekf_proto_decode_fd_in(fd, &m);
        printf("%d %u %a %a %a\n", st, m.step, m.u, m.y1, m.y4);
    } else if (strcmp(a[0], "enc_fd_out") == 0 && n == 16) {
        caekf_msg_fd_out_t m;
        uint8_t fd[CAEKF_CAN_FD_MAX_LEN];
        int k;
        memset(fd, 0, sizeof fd);
        m.step = (uint16_t)strtoul(a[1], NULL, 0);
        for (k = 0; k < 9; k++) {
            m.x[k] = strtod(a[2 + k], NULL);
        }
        m.p_norm = strtod(a[11], NULL);
        m.p_gg = strtod(a[12], NULL);
        m.info.flags = (uint16_t)strtoul(a[13], NULL, 0);
        m.info.newton_iters = (uint8_t)strtoul(a[14], NULL, 0);
        m.info.step_status = (int8_t)strtol(a[15], NULL, 0);
        print_hex_n(caekf_proto_encode_fd_out(&m, fd), fd, CAEKF_FD_OUT_LEN);
    } else if (strcmp(a[0], "dec_fd_out") == 0 && n == 2) {
        caekf_msg_fd_out_t m;
        uint8_t fd[CAEKF_CAN_FD_MAX_LEN];
        size_t len;
        int st, k;
        memset(&m, 0, sizeof m);
        if (parse_hex(a[1], fd, sizeof fd, &len) != 0 || len != CAEKF_FD_OUT_LEN) {
            return -1;
        }
        st = caekf_proto_decode_fd_out(fd, &m);
        printf("%d %u", st, m.step);
        for (k = 0; k < 9; k++) {
            printf(" %a", m.x[k]);
        }
        printf(" %a %a %u %u %d\n", m.p_norm, m.p_gg, m.info.flags, m.info.newton_iters, m.info.step_status);
    } else if (strcmp(a[0], "seal_fd") == 0 && n == 4 && msg_by_name(a[1], &msg) == 0) {
        caekf_can_frame_t f;
        size_t len;
        int st;
        memset(&f, 0, sizeof f);
        if (parse_hex(a[3], f.data, sizeof f.data, &len) != 0) {
            return -1;
        }
        st = caekf_proto_seal(msg, (uint8_t)strtoul(a[2], NULL, 0), &f);
        print_hex_n(st, f.data, f.dlc);
    } else {
        return -1;
    }
    return 0;
}

int main(void)
{
    char line[LINE_MAX_LEN];
    while (fgets(line, sizeof line, stdin) != NULL) {
        if (run(line) != 0) {
            printf("error: bad command: %s", line);
        }
        fflush(stdout);
    }
    return 0;
}
