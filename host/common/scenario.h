/* The scenario file: flat `key = value` lines (valid TOML), shared with the Python simulator. */
#ifndef CAEKF_HOST_SCENARIO_H
#define CAEKF_HOST_SCENARIO_H

typedef struct {
    double m1, m2, m3, m4;
    double k1, k12, k34, k4;
    double c1, c12, c34, c4;
    double gap, gamma, u_amp, u_freq, u_phase, dt, t_end;
    double truth_substeps, noise_std, seed;
    double gamma0, sigma_q0, sigma_v0, sigma_gamma0, sigma_qx_q, sigma_qx_v, sigma_q_gamma, sigma_r, gamma_min;
} caekf_scenario_t;

/* Reads and checks a scenario file. Every key above is required; unknown keys, duplicates and
 * malformed lines are errors. On failure returns nonzero and writes a message with the line number. */
int caekf_scenario_load(const char *path, caekf_scenario_t *sc, char *err, unsigned err_len);

/* Input force u(t) = u_amp sin(2 pi u_freq t + u_phase). */
double caekf_scenario_input(const caekf_scenario_t *sc, double t);

/* Number of estimator steps, round(t_end / dt). */
long caekf_scenario_steps(const caekf_scenario_t *sc);

#endif
