/* Linux CAN_RAW HAL. Errors name their cause and a fix: most first-time failures are a missing vcan
 * interface or a kernel without CAN. */

#include "socketcan_hal.h"

#include <errno.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

static int fail(char *err, unsigned err_len, const char *fmt, const char *a, const char *b)
{
    snprintf(err, err_len, fmt, a, b);
    return -1;
}

static uint32_t clock_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u);
}

static int set_filters(int fd, int32_t id_offset)
{
    struct can_filter filters[CAEKF_MSG_COUNT];
    unsigned i, n = 0;
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        const caekf_msg_info_t *info;
        uint32_t id = 0;
        if (caekf_proto_msg_info((caekf_msg_t)i, &info) == CAEKF_PROTO_OK && info->dir == CAEKF_DIR_TO_ESTIMATOR &&
            caekf_proto_bus_id((caekf_msg_t)i, id_offset, &id) == CAEKF_PROTO_OK) {
            filters[n].can_id = id;
            /* the flag bits in the mask make extended and remote frames with the same number miss */
            filters[n].can_mask = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG;
            n++;
        }
    }
    return setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters, (socklen_t)(n * sizeof filters[0]));
}

int socketcan_open(socketcan_t *s, const char *iface, int kernel_filter, int32_t id_offset, char *err, unsigned err_len)
{
    struct sockaddr_can addr;
    struct ifreq ifr;
    unsigned i;
    memset(s, 0, sizeof *s);
    s->fd = -1;
    if (strlen(iface) >= IFNAMSIZ) {
        return fail(err, err_len, "interface name '%s' is too long%s", iface, "");
    }
    s->ifindex = if_nametoindex(iface);
    if (s->ifindex == 0) {
        return fail(err, err_len,
                    "no network interface '%s' (%s). For a virtual bus: sudo modprobe vcan && sudo ip link add dev "
                    "vcan0 type vcan && sudo ip link set vcan0 up; for hardware pass e.g. --iface can0",
                    iface, strerror(errno));
    }
    s->fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (s->fd < 0) {
        const int e = errno;
        if (e == EAFNOSUPPORT) {
            return fail(
                err, err_len,
                "this kernel has no SocketCAN support: socket(PF_CAN, SOCK_RAW, CAN_RAW) failed with EAFNOSUPPORT "
                "(%s). Load the modules (sudo modprobe can can_raw vcan) or use a kernel built with CONFIG_CAN, "
                "CONFIG_CAN_RAW and CONFIG_CAN_VCAN (tools/with-vcan.sh runs it in user-mode Linux)%s",
                strerror(e), "");
        }
        if (e == EPROTONOSUPPORT) {
            return fail(err, err_len, "CAN is there but not CAN_RAW (%s): sudo modprobe can_raw%s", strerror(e), "");
        }
        return fail(err, err_len, "socket(PF_CAN, SOCK_RAW, CAN_RAW) failed: %s%s", strerror(e), "");
    }
    { /* a deep receive queue rides out scheduling stalls of a loaded machine (FORCE needs root; else capped) */
        int rcvbuf = 4 << 20;
        if (setsockopt(s->fd, SOL_SOCKET, SO_RCVBUFFORCE, &rcvbuf, sizeof rcvbuf) != 0) {
            (void)setsockopt(s->fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
        }
    }
    {
        int on = 1;
        s->fd_frames = setsockopt(s->fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) == 0;
    }
    if (kernel_filter && set_filters(s->fd, id_offset) != 0) {
        snprintf(err, err_len, "setsockopt(CAN_RAW_FILTER) failed: %s", strerror(errno));
        socketcan_close(s);
        return -1;
    }
    memset(&addr, 0, sizeof addr);
    addr.can_family = AF_CAN;
    addr.can_ifindex = (int)s->ifindex;
    if (bind(s->fd, (struct sockaddr *)&addr, sizeof addr) != 0) {
        const int e = errno;
        socketcan_close(s);
        if (e == ENODEV) {
            return fail(err, err_len, "'%s' is not a CAN interface (bind: %s)", iface, strerror(e));
        }
        return fail(err, err_len, "bind to '%s' failed: %s", iface, strerror(e));
    }
    memset(&ifr, 0, sizeof ifr);
    memcpy(ifr.ifr_name, iface, strlen(iface) + 1u);
    if (ioctl(s->fd, SIOCGIFFLAGS, &ifr) == 0 && !(ifr.ifr_flags & IFF_UP)) {
        socketcan_close(s);
        return fail(err, err_len, "interface '%s' is down: sudo ip link set %s up", iface, iface);
    }
    for (i = 0; i < SOCKETCAN_BATCH; i++) {
        s->rx_iov[i].iov_base = &s->rx[i];
        s->rx_iov[i].iov_len = sizeof s->rx[i];
        s->rx_msg[i].msg_hdr.msg_iov = &s->rx_iov[i];
        s->rx_msg[i].msg_hdr.msg_iovlen = 1;
        s->tx_iov[i].iov_base = &s->tx[i];
        s->tx_iov[i].iov_len = sizeof s->tx[i];
        s->tx_msg[i].msg_hdr.msg_iov = &s->tx_iov[i];
        s->tx_msg[i].msg_hdr.msg_iovlen = 1;
    }
    s->timeout_ms = -1;
    s->now_us = clock_us();
    return 0;
}

void socketcan_close(socketcan_t *s)
{
    if (s->fd >= 0) {
        close(s->fd);
    }
    s->fd = -1;
}

int socketcan_wait(socketcan_t *s, int timeout_ms)
{
    int n;
    if (s->rx_i < s->rx_n) {
        return 1; /* the last batch is not used up yet (the app takes at most max_frames_per_poll) */
    }
    s->rx_i = 0;
    s->rx_n = 0;
    if (timeout_ms != s->timeout_ms) { /* a blocking recvmmsg with SO_RCVTIMEO: no poll() per wake-up */
        struct timeval tv;
        tv.tv_sec = timeout_ms / 1000;
        tv.tv_usec = (timeout_ms % 1000) * 1000;
        if (setsockopt(s->fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv) != 0) {
            return -1;
        }
        s->timeout_ms = timeout_ms;
    }
    n = recvmmsg(s->fd, s->rx_msg, SOCKETCAN_BATCH, MSG_WAITFORONE, NULL);
    s->syscalls_rx++;
    s->now_us = clock_us();
    if (n < 0) {
        return (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) ? 0 : -1;
    }
    s->rx_n = (unsigned)n;
    return n > 0 ? 1 : 0;
}

int socketcan_flush(socketcan_t *s)
{
    unsigned done = 0, tries = 0;
    int rc;
    while (done < s->tx_n && tries < 64u) {
        int r = sendmmsg(s->fd, &s->tx_msg[done], s->tx_n - done, 0);
        s->syscalls_tx++;
        tries++;
        if (r < 0) {
            if (errno == ENOBUFS || errno == EAGAIN || errno == EINTR) {
                continue; /* the interface queue is full for a moment */
            }
            if (errno == ENETDOWN && !s->warned_down) {
                s->warned_down = 1;
                fprintf(stderr, "caekf-host: transmit failed: the interface went down (ENETDOWN)\n");
            }
            break;
        }
        done += (unsigned)r;
    }
    rc = (done < s->tx_n) ? -1 : 0;
    s->tx_dropped += s->tx_n - done;
    s->tx_n = 0;
    return rc;
}

static int hal_receive(void *ctx, caekf_can_frame_t *frame)
{
    socketcan_t *s = (socketcan_t *)ctx;
    const struct canfd_frame *cf;
    unsigned len, i;
    if (s->rx_i >= s->rx_n) {
        return 0; /* the batch is used up; the main loop waits for the next */
    }
    i = s->rx_i++;
    cf = &s->rx[i];
    if (s->rx_msg[i].msg_len != CAN_MTU && s->rx_msg[i].msg_len != CANFD_MTU) {
        s->rx_dropped_foreign++;
        return -EMSGSIZE;
    }
    if (cf->can_id & CAN_RTR_FLAG) { /* no caekf message is a remote frame (the MCU HAL refuses them too) */
        s->rx_rtr++;
        return -EBADMSG;
    }
    frame->id = (cf->can_id & CAN_EFF_FLAG) ? ((cf->can_id & CAN_EFF_MASK) | CAEKF_CAN_ID_EXT_FLAG)
                                            : (cf->can_id & CAN_SFF_MASK);
    len = cf->len; /* struct can_frame's length byte sits at the same offset */
    if (len > sizeof frame->data) {
        s->rx_dropped_foreign++;
        return -EMSGSIZE;
    }
    frame->dlc = (uint8_t)len;
    memcpy(frame->data, cf->data, len);
    return 1;
}

static int hal_transmit(void *ctx, const caekf_can_frame_t *frame)
{
    socketcan_t *s = (socketcan_t *)ctx;
    struct canfd_frame *cf;
    if (frame->dlc > sizeof cf->data || (frame->dlc > CAN_MAX_DLEN && !s->fd_frames)) {
        return -EMSGSIZE;
    }
    if (s->tx_n >= SOCKETCAN_BATCH && socketcan_flush(s) != 0) {
        return -EIO;
    }
    cf = &s->tx[s->tx_n];
    memset(cf, 0, sizeof *cf);
    cf->can_id = frame->id & CAN_SFF_MASK;
    cf->len = frame->dlc;
    memcpy(cf->data, frame->data, frame->dlc);
    s->tx_iov[s->tx_n].iov_len = CAN_MTU;
    if (frame->dlc > CAN_MAX_DLEN) { /* a CAN FD frame, data phase at the data bit rate */
        cf->flags = CANFD_BRS | CANFD_FDF;
        s->tx_iov[s->tx_n].iov_len = CANFD_MTU;
    }
    s->tx_n++;
    return 0;
}

static uint32_t hal_now_us(void *ctx)
{
    const socketcan_t *s = (const socketcan_t *)ctx;
    return s->now_us; /* the time the frames being handled were taken from the socket */
}

void socketcan_hal(socketcan_t *s, caekf_app_hal_t *hal)
{
    hal->ctx = s;
    hal->receive = hal_receive;
    hal->transmit = hal_transmit;
    hal->now_us = hal_now_us;
    s->now_us = clock_us();
}
