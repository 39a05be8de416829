/* A user's firmware built against an installed caekf (find_package(caekf)): the paper's mechanism set by
 * parameter id, then a few steps. Exit 0 when every step is accepted and gamma stays finite. */
#include <math.h>
#include <stdio.h>

#include "caekf/caekf.h"

static const struct {
    unsigned id;
    double value;
} config[] = {
    {CAEKF_PARAM_M + 0, 1.0},          {CAEKF_PARAM_M + 1, 1.0},          {CAEKF_PARAM_M + 2, 1.0},
    {CAEKF_PARAM_M + 3, 1.0},          {CAEKF_PARAM_SPRING_K + 0, 2.0e3}, {CAEKF_PARAM_SPRING_K + 1, 1.0e4},
    {CAEKF_PARAM_SPRING_K + 2, 1.0e4}, {CAEKF_PARAM_SPRING_K + 3, 1.0e4}, {CAEKF_PARAM_SPRING_C + 0, 5.0},
    {CAEKF_PARAM_SPRING_C + 1, 5.0},   {CAEKF_PARAM_SPRING_C + 2, 5.0},   {CAEKF_PARAM_SPRING_C + 3, 5.0},
    {CAEKF_PARAM_CONTACT_GAP, 1.0e-3}, {CAEKF_PARAM_DT, 1.0e-3},          {CAEKF_PARAM_GAMMA0, 7.5e7},
    {CAEKF_PARAM_SIGMA_Q0, 1.0e-6},    {CAEKF_PARAM_SIGMA_V0, 1.0e-5},    {CAEKF_PARAM_SIGMA_GAMMA0, 2.5e7},
    {CAEKF_PARAM_SIGMA_QX_Q, 1.0e-9},  {CAEKF_PARAM_SIGMA_QX_V, 1.0e-7},  {CAEKF_PARAM_SIGMA_Q_GAMMA, 1.0e6},
    {CAEKF_PARAM_SIGMA_R, 1.0e-7},     {CAEKF_PARAM_GAMMA_MIN, 1.0e6},
};

int main(void)
{
    caekf_settings_t s;
    caekf_t est;
    caekf_scalar_t y[CAEKF_MAX_SENSORS] = {0, 0}, gamma = 0;
    unsigned i;
    int k;
    (void)caekf_settings_default(&s);
    for (i = 0; i < sizeof config / sizeof config[0]; ++i) {
        if (caekf_settings_set(&s, config[i].id, config[i].value, NULL) != CAEKF_OK) {
            fprintf(stderr, "example: parameter id %u refused\n", config[i].id);
            return 1;
        }
    }
    if (caekf_init(&est, &s) != CAEKF_OK) {
        fprintf(stderr, "example: settings refused\n");
        return 1;
    }
    for (k = 0; k < 100; ++k) {
        if (caekf_step(&est, (const caekf_scalar_t[]){(caekf_scalar_t)0.1}, y, NULL) != CAEKF_OK) {
            fprintf(stderr, "example: step %d refused\n", k);
            return 1;
        }
    }
    (void)caekf_get_gamma(&est, &gamma);
    printf("example firmware: 100 steps, gamma %g\n", (double)gamma);
    return isfinite((double)gamma) ? 0 : 1;
}
