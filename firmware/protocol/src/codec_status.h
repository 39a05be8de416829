/* Private to the codec: the status of an encode or a decode around cantools' generated pack and unpack. */
#ifndef CAEKF_PROTO_CODEC_STATUS_H
#define CAEKF_PROTO_CODEC_STATUS_H

#include <stddef.h>

#include "caekf/caekf_proto.h"

/* An encode's status from the generated pack's result (the bytes written) and whether a value was clipped. */
static inline caekf_proto_status_t caekf_proto_packed(int written, unsigned len, int clipped)
{
    if (written != (int)len) {
        return CAEKF_PROTO_ERR_MSG;
    }
    return clipped ? CAEKF_PROTO_SATURATED : CAEKF_PROTO_OK;
}

/* A decode's status before its fields: its arguments given (else ERR_NULL), then the generated unpack's result
 * (else ERR_MSG); unpack is only called with the arguments given. */
#define CAEKF_PROTO_UNPACKED(m, data, unpack_call) \
    ((m) == NULL || (data) == NULL ? CAEKF_PROTO_ERR_NULL : (unpack_call) != 0 ? CAEKF_PROTO_ERR_MSG : CAEKF_PROTO_OK)

#endif /* CAEKF_PROTO_CODEC_STATUS_H */
