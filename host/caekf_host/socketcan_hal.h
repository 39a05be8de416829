/* The app's HAL on Linux SocketCAN (CAN_RAW): works the same on vcan0 and on a real can0. */
#ifndef CAEKF_SOCKETCAN_HAL_H
#define CAEKF_SOCKETCAN_HAL_H

#include "caekf/caekf_app.h"

#include <linux/can.h>
#include <sys/socket.h>

/* Frames moved per recvmmsg/sendmmsg. Batching is what makes the host cheap where every system call
 * is trapped (user-mode Linux: ~20 us each): one wait, one clock read and one send per wake-up. */
#define SOCKETCAN_BATCH 256u

typedef struct {
    int fd;
    unsigned ifindex;
    int warned_down;                        /* ENETDOWN reported once */
    unsigned long rx_dropped_foreign;       /* reads that were not one CAN or CAN FD frame */
    unsigned long rx_rtr;                   /* remote frames refused (reported to the app as HAL errors) */
    unsigned long tx_dropped;               /* frames the interface refused (counted by the app as TX errors) */
    unsigned long syscalls_rx, syscalls_tx; /* recvmmsg / sendmmsg calls (statistics) */
    int timeout_ms;                         /* SO_RCVTIMEO currently set (-1: none yet) */
    uint32_t now_us;                        /* CLOCK_MONOTONIC when the current receive batch was taken */
    unsigned rx_n, rx_i, tx_n;              /* frames in rx[], next to hand out, queued in tx[] */
    int fd_frames;                          /* CAN_RAW_FD_FRAMES on: CAN FD frames are read and can be sent */
    struct canfd_frame rx[SOCKETCAN_BATCH]; /* a classic frame fills the first CAN_MTU bytes (same layout) */
    struct canfd_frame tx[SOCKETCAN_BATCH]; /* sent as CAN_MTU (classic) or CANFD_MTU (len > 8, bit-rate switch) */
    struct iovec rx_iov[SOCKETCAN_BATCH], tx_iov[SOCKETCAN_BATCH];
    struct mmsghdr rx_msg[SOCKETCAN_BATCH], tx_msg[SOCKETCAN_BATCH];
} socketcan_t;

/* Opens a CAN_RAW socket on `iface`. By default every data frame on the bus reaches the app, which
 * counts each foreign one (RX_UNKNOWN_ID): nothing on the bus goes unseen. kernel_filter != 0 installs
 * kernel acceptance filters for exactly the messages the estimator receives (standard data frames),
 * as a busy real bus may need: foreign traffic is then dropped uncounted, like behind an MCU's
 * hardware filter (at the bus IDs: DBC ID + id_offset). CAN FD frames are enabled (CAN_RAW_FD_FRAMES) where
 * the kernel has them; an FD frame needs an FD interface (vcan: `ip link set vcan0 mtu 72`; a real controller:
 * `fd on`), else its send fails and is counted as a TX error. Returns 0, or -1 with a human-readable reason
 * in err. */
int socketcan_open(socketcan_t *s, const char *iface, int kernel_filter, int32_t id_offset, char *err,
                   unsigned err_len);
void socketcan_close(socketcan_t *s);

/* Waits until frames are readable or timeout_ms passed and takes up to SOCKETCAN_BATCH of them in one
 * recvmmsg (the HAL's receive hands them out; its now_us is the time they were taken). Returns 1 with
 * frames, 0 on timeout or signal, -1 on error. */
int socketcan_wait(socketcan_t *s, int timeout_ms);

/* Sends the frames the app queued through the HAL's transmit (one sendmmsg). 0, or -1 on error. */
int socketcan_flush(socketcan_t *s);

/* Fills the app HAL with this socket's receive/transmit and CLOCK_MONOTONIC. */
void socketcan_hal(socketcan_t *s, caekf_app_hal_t *hal);

#endif
