#include "truth.h"

#include <math.h>
#include <stdint.h>

#include "caekf/caekf_model.h"

#define CAEKF_PI 3.141592653589793238462643383279502884

/* splitmix64 (public-domain constants), uniform in (0, 1] from its top 53 bits. */
static double uniform01(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return ((double)(z >> 11) + 1.0) * (1.0 / 9007199254740992.0);
}

/* One normal deviate per call (Box-Muller, cosine branch only: simple to reproduce). */
static double gaussian(uint64_t *state)
{
    double u1 = uniform01(state);
    double u2 = uniform01(state);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * CAEKF_PI * u2);
}

int caekf_truth_run(const caekf_scenario_t *sc, int (*emit)(const caekf_truth_sample_t *, void *), void *ctx)
{
    caekf_model_params_t p;
    caekf_model_t model;
    double x[CAEKF_N] = {0}, xn[CAEKF_N];
    long steps = caekf_scenario_steps(sc);
    int sub = (int)sc->truth_substeps;
    double h = sc->dt / sub;
    uint64_t rng = (uint64_t)sc->seed;
    long k;
    int s, i;
    caekf_scenario_model(sc, h, &p);
    if (caekf_model_init(&model, &p) != 0) {
        return -1;
    }
    x[CAEKF_IG] = sc->gamma;
    for (k = 1; k <= steps; ++k) {
        caekf_truth_sample_t out;
        caekf_contact_t c;
        out.newton_iters = 0;
        out.newton_failed = 0;
        for (s = 1; s <= sub; ++s) {
            double t = (double)(k - 1) * sc->dt + (double)s * h;
            int it = 0;
            if (caekf_model_newton(&model, x, caekf_scenario_input(sc, t), CAEKF_NEWTON_MAX_ITER, DBL_EPSILON * 256, xn,
                                   &it) != 0) {
                out.newton_failed++;
            }
            out.newton_iters += it;
            for (i = 0; i < CAEKF_N; ++i) {
                x[i] = xn[i];
            }
        }
        caekf_model_contact(&model, x, x[CAEKF_IG], &c);
        out.t = (double)k * sc->dt;
        out.u = caekf_scenario_input(sc, out.t);
        for (i = 0; i < 4; ++i) {
            out.q[i] = x[i];
            out.v[i] = x[4 + i];
        }
        out.delta = c.delta;
        out.y1 = out.q[0];
        out.y4 = out.q[3];
        if (sc->noise_std > 0) {
            out.y1 += sc->noise_std * gaussian(&rng);
            out.y4 += sc->noise_std * gaussian(&rng);
        }
        if (emit(&out, ctx) != 0) {
            return -1;
        }
    }
    return 0;
}
