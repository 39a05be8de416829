/*
 * replay.c - the reference scenario on the MCU with the switched-highq-constrained preset (target_replay),
 * or with no preset: the recommended default estimator (target_replay_default, REPLAY_PRESET -1); with
 * REPLAY_PSD_CHECK_PERIOD 1 the full PSD test of P runs on every step (target_replay_default_worst: every
 * contact step then also pays for it, the constructed worst case of tools/mcu-report.py).
 *
 * Inputs: the inputs and the measurements of every step (u, y1, y4 for the paper's mechanism; any
 * mechanism's: CAEKF_SCENARIO), from caekf-truth on the host, embedded as const data in flash by
 * replay_inputs.S (.incbin of a file written by gen_replay_data.py), in the build's scalar type: for the
 * paper 60,000 steps x 3 x 8 B = 1.44 MB (double, Cortex-M7) or 720 KB (float, Cortex-M4F), within the
 * 4 MB of the MPS2's SSRAM1. The settings are the schema's defaults, the scenario's values and the
 * preset's, from the fixture generated from the schema and the scenario (caekf_fixture_settings.h, the
 * unit tests' too): no scenario parser on the target.
 *
 * Each caekf_step() is bracketed by caekf_mark_begin()/caekf_mark_end() for tools/qemu-icount.
 * The stack is painted before caekf_init() and again before the first step; the high-water marks
 * are printed ("stack:" line): init = caekf_init, steps = caekf_step plus the small accessors
 * (caekf_get_state/get_covariance) of the snapshots, measured from main's stack pointer. Every REPLAY_EVERY steps (and at the last step) a snapshot of the
 * state is kept in RAM and printed after the run as exact bit patterns; one class word per step
 * (flags | newton_iters << 9 | not-ok << 15) is printed in hex for mcu-report's worst-case search.
 *
 * Output lines (parsed by check_replay.py and tools/mcu-report.py):
 *   replay: mcu=... scalar=... steps=N preset=switched-highq-constrained
 *   S k x0 .. x8 p_gg flags iters        (k: 1-based step; values as 16-hex-digit binary64)
 *   C hhhh hhhh ...                      (class words, 64 per line, in step order)
 *   summary: gamma=... gamma_bits=... rejected=.. iters_max=.. flags_seen=0x..
 *   stack: init=B steps=B reserved=B
 *   replay: done
 * Exit status 0 unless the settings were refused or a step returned an error.
 */
#include <stddef.h>
#include <stdint.h>

#include "caekf/caekf.h"
#include "caekf_port.h"
#include "caekf_fixture_settings.h" /* generated: the reference scenario's values and the presets */

#ifndef REPLAY_EVERY
#define REPLAY_EVERY 100u
#endif

#ifndef REPLAY_PRESET
#define REPLAY_PRESET CAEKF_FIXTURE_PRESET_SWITCHED_HIGHQ_CONSTRAINED
#endif
extern const caekf_scalar_t caekf_replay_inputs[]; /* the inputs, then the measurements, per step */
extern const caekf_scalar_t caekf_replay_inputs_end[];

typedef struct {
    uint32_t k;
    uint16_t flags;
    uint8_t iters;
    double x[CAEKF_N];
    double p_gg;
} snapshot_t;

#define MAX_STEPS 60000u
#define MAX_SNAPSHOTS (MAX_STEPS / REPLAY_EVERY + 2u)

static snapshot_t snapshots[MAX_SNAPSHOTS];
static uint16_t classes[MAX_STEPS];
static caekf_t est;

static void put_scalar_bits(double v)
{
    caekf_console_putc(' ');
    caekf_console_put_f64_bits(v);
}

/* Static, so that the snapshot's buffers do not count in the measured stack (only the accessors'
 * own frames do). */
static caekf_scalar_t snap_x[CAEKF_N];
static caekf_scalar_t snap_P[CAEKF_N][CAEKF_N];

/* The schema's defaults, the scenario's values, then the preset's. */
static void replay_settings(caekf_settings_t *s)
{
    unsigned i;
    (void)caekf_settings_default(s);
    for (i = 0u; i < CAEKF_N_SCENARIO_PARAMS; ++i) {
        (void)caekf_settings_set(s, caekf_scenario_params[i].id, caekf_scenario_params[i].value, NULL);
    }
#if REPLAY_PRESET >= 0
    for (i = 0u; i < caekf_fixture_presets[REPLAY_PRESET].n; ++i) {
        (void)caekf_settings_set(s, caekf_fixture_presets[REPLAY_PRESET].id[i],
                                 caekf_fixture_presets[REPLAY_PRESET].value[i], NULL);
    }
#endif
#ifdef REPLAY_PSD_CHECK_PERIOD /* the constructed worst case: the full PSD test on every step */
    s->psd_check_period = REPLAY_PSD_CHECK_PERIOD;
#endif
}

static void take_snapshot(snapshot_t *s, uint32_t k, const caekf_report_t *rep)
{
    caekf_scalar_t *x = snap_x;
    caekf_scalar_t(*P)[CAEKF_N] = snap_P;
    int i;
    (void)caekf_get_state(&est, x);
    (void)caekf_get_covariance(&est, P);
    s->k = k;
    s->flags = (uint16_t)rep->flags;
    s->iters = (uint8_t)rep->newton_iters;
    for (i = 0; i < CAEKF_N; ++i) {
        s->x[i] = (double)x[i];
    }
    s->p_gg = (double)P[2 * est.model.nq][2 * est.model.nq];
}

int main(void)
{
    caekf_settings_t s;
    caekf_report_t rep;
    caekf_setting_error_t err;
    const char *bad;
    uint32_t steps, width;
    uint32_t k, n_snap = 0u, rejected = 0u, flags_seen = 0u;
    int iters_max = 0;
    uintptr_t top;
    size_t stack_init, stack_steps;
    caekf_scalar_t gamma = 0;
    caekf_status_t st;

    replay_settings(&s);
    width = (uint32_t)(s.model.inputs + s.model.sensors); /* counts within the capacity: validated below */
    steps = width > 0u ? (uint32_t)((size_t)(caekf_replay_inputs_end - caekf_replay_inputs) / width) : 0u;
    caekf_console_puts("replay: mcu=" CAEKF_REPLAY_MCU " scalar=" CAEKF_SCALAR_NAME " steps=");
    caekf_console_put_u32(steps);
    caekf_console_puts(" preset=");
#if REPLAY_PRESET >= 0
    caekf_console_puts(caekf_fixture_presets[REPLAY_PRESET].name);
#else
    caekf_console_puts("default");
#endif
    caekf_console_putc('\n');
    if (steps > MAX_STEPS) {
        caekf_console_puts("replay: too many steps for the snapshot buffers\n");
        return 2;
    }

    if (caekf_settings_validate(&s, &err) != CAEKF_OK) {
        bad = caekf_param_key(err.param_id);
        caekf_console_puts("replay: settings refused: ");
        caekf_console_puts(bad != NULL ? bad : "?");
        caekf_console_putc('\n');
        return 3;
    }

    top = caekf_stack_paint();
    st = caekf_init(&est, &s);
    stack_init = caekf_stack_used_since(top);
    if (st != CAEKF_OK) {
        caekf_console_puts("replay: caekf_init failed\n");
        return 3;
    }

    top = caekf_stack_paint();
    for (k = 0u; k < steps; ++k) {
        const caekf_scalar_t *in = &caekf_replay_inputs[width * k];
        uint32_t cls;
        caekf_mark_begin();
        st = caekf_step(&est, in, in + s.model.inputs, &rep);
        caekf_mark_end();
        cls = (rep.flags & 0x1FFu) | ((uint32_t)(rep.newton_iters > 31 ? 31 : rep.newton_iters) << 9);
        if (st != CAEKF_OK) {
            ++rejected;
            cls |= 0x8000u;
        }
        classes[k] = (uint16_t)cls;
        flags_seen |= rep.flags;
        if (rep.newton_iters > iters_max) {
            iters_max = rep.newton_iters;
        }
        if ((k + 1u) % REPLAY_EVERY == 0u || k + 1u == steps) {
            take_snapshot(&snapshots[n_snap++], k + 1u, &rep);
        }
    }
    stack_steps = caekf_stack_used_since(top);
    (void)caekf_get_gamma(&est, &gamma);

    for (k = 0u; k < n_snap; ++k) {
        const snapshot_t *p = &snapshots[k];
        int i;
        caekf_console_puts("S ");
        caekf_console_put_u32(p->k);
        for (i = 0; i < CAEKF_N; ++i) {
            put_scalar_bits(p->x[i]);
        }
        put_scalar_bits(p->p_gg);
        caekf_console_putc(' ');
        caekf_console_put_u32(p->flags);
        caekf_console_putc(' ');
        caekf_console_put_u32(p->iters);
        caekf_console_putc('\n');
    }
    for (k = 0u; k < steps; ++k) {
        static const char hex[] = "0123456789abcdef";
        if (k % 64u == 0u) {
            caekf_console_putc('C');
        }
        caekf_console_putc(' ');
        caekf_console_putc(hex[(classes[k] >> 12) & 0xFu]);
        caekf_console_putc(hex[(classes[k] >> 8) & 0xFu]);
        caekf_console_putc(hex[(classes[k] >> 4) & 0xFu]);
        caekf_console_putc(hex[classes[k] & 0xFu]);
        if (k % 64u == 63u || k + 1u == steps) {
            caekf_console_putc('\n');
        }
    }
    caekf_console_puts("summary: gamma=");
    caekf_console_put_f64((double)gamma, 12);
    caekf_console_puts(" gamma_bits=");
    caekf_console_put_f64_bits((double)gamma);
    caekf_console_puts(" rejected=");
    caekf_console_put_u32(rejected);
    caekf_console_puts(" iters_max=");
    caekf_console_put_i32(iters_max);
    caekf_console_puts(" flags_seen=0x");
    caekf_console_put_hex32(flags_seen);
    caekf_console_puts("\nstack: init=");
    caekf_console_put_u32((uint32_t)stack_init);
    caekf_console_puts(" steps=");
    caekf_console_put_u32((uint32_t)stack_steps);
    caekf_console_puts(" reserved=");
    caekf_console_put_u32((uint32_t)caekf_stack_size());
    caekf_console_puts("\nreplay: done\n");
    return rejected == 0u ? 0 : 4;
}
