/* Linux CAN_RAW HAL. Errors name their cause and a fix: most first-time failures are a missing vcan
 * interface or a kernel without CAN. */
#define _DEFAULT_SOURCE /* struct ifreq, SIOCGIFFLAGS */

#include "socketcan_hal.h"

#include <errno.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

/* struct can_frame's length field was renamed from can_dlc to len in Linux 5.11. */
#ifdef CAN_MAX_RAW_DLC
#define FRAME_LEN(cf) ((cf).len)
#else
#define FRAME_LEN(cf) ((cf).can_dlc)
#endif

static int fail(char *err, unsigned err_len, const char *fmt, const char *a, const char *b)
{
    snprintf(err, err_len, fmt, a, b);
    return -1;
}

static int set_filters(int fd)
{
    struct can_filter filters[CAEKF_MSG_COUNT];
    unsigned i, n = 0;
    for (i = 0; i < (unsigned)CAEKF_MSG_COUNT; i++) {
        const caekf_msg_info_t *info;
        if (caekf_proto_msg_info((caekf_msg_t)i, &info) == CAEKF_PROTO_OK && info->dir == CAEKF_DIR_TO_ESTIMATOR) {
            filters[n].can_id = info->can_id;
            /* the flag bits in the mask make extended and remote frames with the same number miss */
            filters[n].can_mask = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG;
            n++;
        }
    }
    return setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters, (socklen_t)(n * sizeof filters[0]));
}

int socketcan_open(socketcan_t *s, const char *iface, int kernel_filter, char *err, unsigned err_len)
{
    struct sockaddr_can addr;
    struct ifreq ifr;
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
            return fail(err, err_len,
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
    if (kernel_filter && set_filters(s->fd) != 0) {
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
    struct pollfd p;
    int r;
    p.fd = s->fd;
    p.events = POLLIN;
    p.revents = 0;
    r = poll(&p, 1, timeout_ms);
    if (r < 0) {
        return (errno == EINTR) ? 0 : -1;
    }
    if (r > 0 && (p.revents & POLLERR)) {
        int soerr = 0;
        socklen_t len = sizeof soerr;
        (void)getsockopt(s->fd, SOL_SOCKET, SO_ERROR, &soerr, &len); /* reading clears it */
    }
    return (r > 0 && (p.revents & POLLIN)) ? 1 : 0;
}

static int hal_receive(void *ctx, caekf_can_frame_t *frame)
{
    socketcan_t *s = (socketcan_t *)ctx;
    struct can_frame cf;
    ssize_t n;
    unsigned len;
    n = recv(s->fd, &cf, sizeof cf, MSG_DONTWAIT);
    if (n < 0) {
        return (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) ? 0 : -errno;
    }
    if ((size_t)n != sizeof cf) {
        s->rx_dropped_foreign++;
        return -EMSGSIZE;
    }
    if (cf.can_id & CAN_RTR_FLAG) { /* no caekf message is a remote frame (the MCU HAL refuses them too) */
        s->rx_rtr++;
        return -EBADMSG;
    }
    frame->id = (cf.can_id & CAN_EFF_FLAG) ? ((cf.can_id & CAN_EFF_MASK) | CAEKF_CAN_ID_EXT_FLAG)
                                           : (cf.can_id & CAN_SFF_MASK);
    len = FRAME_LEN(cf);
    frame->dlc = (uint8_t)len;
    memcpy(frame->data, cf.data, sizeof frame->data);
    return 1;
}

static int hal_transmit(void *ctx, const caekf_can_frame_t *frame)
{
    socketcan_t *s = (socketcan_t *)ctx;
    struct can_frame cf;
    memset(&cf, 0, sizeof cf);
    cf.can_id = frame->id & CAN_SFF_MASK;
    FRAME_LEN(cf) = frame->dlc;
    memcpy(cf.data, frame->data, sizeof cf.data);
    if (write(s->fd, &cf, sizeof cf) != (ssize_t)sizeof cf) {
        if (errno == ENETDOWN && !s->warned_down) {
            s->warned_down = 1;
            fprintf(stderr, "caekf-host: transmit failed: the interface went down (ENETDOWN)\n");
        }
        return -errno;
    }
    return 0;
}

static uint32_t hal_now_us(void *ctx)
{
    struct timespec ts;
    (void)ctx;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u);
}

void socketcan_hal(socketcan_t *s, caekf_app_hal_t *hal)
{
    hal->ctx = s;
    hal->receive = hal_receive;
    hal->transmit = hal_transmit;
    hal->now_us = hal_now_us;
}
