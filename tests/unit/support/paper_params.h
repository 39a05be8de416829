/* The reference scenario's estimator settings (sim/scenarios/paper.toml) as CTRL_PARAM values in their
 * shortest decimal form, value = mantissa * 10^exp10, as the bench sends them. One table for every
 * C test that configures the app over CAN (app fixture, fuzz harness, MCU self-test). */
#ifndef CAEKF_PAPER_PARAMS_H
#define CAEKF_PAPER_PARAMS_H

#include <stdint.h>

#include "caekf/caekf_proto_ids.h"

typedef struct {
    uint8_t id; /* CAEKF_PARAM_* */
    int8_t exp10;
    int32_t mantissa;
} caekf_paper_param_t;

static const caekf_paper_param_t caekf_paper_params[] = {
    {CAEKF_PARAM_M1, 0, 1},          {CAEKF_PARAM_M2, 0, 1},          {CAEKF_PARAM_M3, 0, 1},
    {CAEKF_PARAM_M4, 0, 1},          {CAEKF_PARAM_K1, 3, 2},          {CAEKF_PARAM_K12, 4, 1},
    {CAEKF_PARAM_K34, 4, 1},         {CAEKF_PARAM_K4, 4, 1},          {CAEKF_PARAM_C1, 0, 5},
    {CAEKF_PARAM_C12, 0, 5},         {CAEKF_PARAM_C34, 0, 5},         {CAEKF_PARAM_C4, 0, 5},
    {CAEKF_PARAM_GAP, -3, 1},        {CAEKF_PARAM_DT, -3, 1},         {CAEKF_PARAM_GAMMA0, 6, 75},
    {CAEKF_PARAM_SIGMA_Q0, -6, 1},   {CAEKF_PARAM_SIGMA_V0, -5, 1},   {CAEKF_PARAM_SIGMA_GAMMA0, 6, 25},
    {CAEKF_PARAM_SIGMA_QX_Q, -9, 1}, {CAEKF_PARAM_SIGMA_QX_V, -7, 1}, {CAEKF_PARAM_SIGMA_Q_GAMMA, 6, 1},
    {CAEKF_PARAM_SIGMA_R, -7, 1},    {CAEKF_PARAM_GAMMA_MIN, 6, 1},
};
#define CAEKF_N_PAPER_PARAMS ((unsigned)(sizeof caekf_paper_params / sizeof caekf_paper_params[0]))

#endif
