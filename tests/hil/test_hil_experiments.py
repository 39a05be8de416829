"""(a) The paper's four experiments over CAN, full 60 s each, strict lockstep, one running caekf-host.

Runs in the profile CAEKF_HIL_PROFILE (tools/hil-tests.sh: diagnostics, then production).

Two kinds of checks on the same runs:
- equality: every estimate decoded from CAN is caekf-replay's estimate for the same inputs (the values the
  estimator decoded: float32 u, y on the signal's LSB) as that signal encodes it: within half an LSB for
  the scaled integers, half a float32 ULP for the float signals; flags and Newton iterations equal.
  Diagnostics: every value of every step. Production: what it carries -- gamma and the estimator's flags
  of every step (EST_PROD), and the state, P norm, P_gg, Newton iterations at the steps of their EST_PAGE
  page (each compared value counted: a page that never came fails).
- the paper's claims (docs/scenario.md), from the CAN values alone.
"""
import numpy as np
import pytest

from hilcfg import EXPERIMENTS, PROFILE, report


@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_estimates_over_can_equal_replay(full_runs, replay, bench, experiment):
    from caekf_sim.bench.results import compare_with_replay

    run = full_runs[experiment]
    agr = compare_with_replay(run.decoded, replay(experiment), bench.codec, bench.profile)
    report(f"[{PROFILE}] {experiment}: CAN vs caekf-replay: {agr.text()}; compared rows {agr.carried}")
    assert agr.ok, agr.text()
    # every column compared where the profile carries it: every step, or (EST_PAGE) 11 of each page period
    n = run.record.n
    for col, rows in agr.carried.items():
        every = bench.profile.results[col].page is None
        assert rows == n if every else rows >= n // 20, (col, rows)


@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_every_step_answered_and_bus_clean(full_runs, experiment):
    run = full_runs[experiment]
    dec = run.decoded
    assert run.record.timeouts == 0
    assert dec.complete.all(), f"{int((~dec.complete).sum())} steps incomplete"
    assert (dec.bad_crc, dec.bad_dlc, dec.counter_duplicates, dec.counter_jumps) == (0, 0, 0, 0)
    h = run.health
    assert h["STEPS_DONE"] == run.record.n
    for name in ("RX_BAD_CRC", "RX_BAD_DLC", "RX_COUNTER_JUMP", "RX_DUPLICATE", "RX_LOST", "RX_BAD_VALUE",
                 "RX_LATE", "RX_REPEATED", "RX_HAL_ERROR", "STEPS_TIMED_OUT", "STEPS_SUPERSEDED", "STEPS_SKIPPED",
                 "TX_ERRORS"):
        assert h[name] == 0, (name, h[name])


def _final_error(run, gamma_true):
    g = run.result.gamma
    return g[-1] / gamma_true - 1.0


# The paper's convergence claims are about (nearly) noise-free measurements: the diagnostics profile carries
# the positions on the 1e-12 m grid, the production profile on BENCH_YP's 1e-9 m grid (replayed on that
# grid: switched -0.236 %, constrained -1.428 % against -0.227 % and -1.416 % at full precision; the
# earlier 2e-8 m grid left them +0.66 % and +4.2 % off). Both profiles are checked.


def test_switched_converges_to_the_true_gamma(full_runs, sc):
    err = _final_error(full_runs["switched"], sc.gamma)
    report(f"claim switched: final gamma error {100 * err:+.3f} % (need within 0.5 %)")
    assert abs(err) < 0.005


def test_canonical_does_not_settle_and_its_covariance_grows(full_runs, sc):
    can, sw = full_runs["canonical"].result, full_runs["switched"].result
    err = _final_error(full_runs["canonical"], sc.gamma)
    ratio = np.nanmax(can.p_norm) / np.nanmax(sw.p_norm)
    report(f"claim canonical: final gamma error {100 * err:+.2f} % (need > 10 %), max ||P|| "
           f"{np.nanmax(can.p_norm):.3g} = {ratio:.3g} x switched's (need > 10)")
    assert abs(err) > 0.10
    assert ratio > 10.0


def test_switched_highq_goes_negative_or_diverges(full_runs, sc):
    from caekf_sim import flags as fl
    from caekf_sim.bench.codec import step_flags

    r = full_runs["switched-highq"].result
    dec = full_runs["switched-highq"].decoded
    flags = int(np.bitwise_or.reduce(r.flags))
    diverged = bool(flags & (fl.NEWTON_NOT_CONVERGED | fl.NUMERIC_ROLLBACK | step_flags()["SATURATED"])) or bool(
        np.any(dec.step_status[dec.complete] != 0))
    report(f"claim switched-highq: min gamma {np.nanmin(r.gamma):.4g}, divergence flagged {diverged}")
    assert np.nanmin(r.gamma) < 0.0 or diverged


def _constrained(full_runs, sc, need: str = ""):
    """The constrained run's gamma (finite and feasible in every profile) and its final error."""
    r = full_runs["switched-highq-constrained"].result
    err = _final_error(full_runs["switched-highq-constrained"], sc.gamma)
    report(f"[{PROFILE}] switched-highq-constrained: min gamma {r.gamma.min():.6g} (gamma_min {sc.gamma_min:g}), "
           f"final gamma error {100 * err:+.3f} %{need}")
    assert np.all(np.isfinite(r.gamma))
    assert r.gamma.min() >= sc.gamma_min
    return err


def test_constraint_keeps_gamma_feasible_and_converges(full_runs, sc):
    assert abs(_constrained(full_runs, sc, " (need < 2 %)")) < 0.02
