/* The app's HAL on Linux SocketCAN (CAN_RAW): works the same on vcan0 and on a real can0. */
#ifndef CAEKF_SOCKETCAN_HAL_H
#define CAEKF_SOCKETCAN_HAL_H

#include "caekf/caekf_app.h"

typedef struct {
    int fd;
    unsigned ifindex;
    int warned_down;         /* ENETDOWN reported once */
    unsigned long rx_dropped_foreign; /* reads that were not one classic CAN frame */
    unsigned long rx_rtr;             /* remote frames refused (reported to the app as HAL errors) */
} socketcan_t;

/* Opens a CAN_RAW socket on `iface`. By default every data frame on the bus reaches the app, which
 * counts each foreign one (RX_UNKNOWN_ID): nothing on the bus goes unseen. kernel_filter != 0 installs
 * kernel acceptance filters for exactly the messages the estimator receives (standard data frames),
 * as a busy real bus may need: foreign traffic is then dropped uncounted, like behind an MCU's
 * hardware filter. Returns 0, or -1 with a human-readable reason in err. */
int socketcan_open(socketcan_t *s, const char *iface, int kernel_filter, char *err, unsigned err_len);
void socketcan_close(socketcan_t *s);

/* Waits until a frame is readable or timeout_ms passed. 1 readable, 0 timeout or signal, -1 error. */
int socketcan_wait(socketcan_t *s, int timeout_ms);

/* Fills the app HAL with this socket's receive/transmit and CLOCK_MONOTONIC. */
void socketcan_hal(socketcan_t *s, caekf_app_hal_t *hal);

#endif
