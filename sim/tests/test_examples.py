"""The example mechanisms (sim/scenarios/shuttle.toml, valve.toml) through the truth and the
reference EKF, and the paper's results under the general model.

Expected contact timing comes from the forcing (quasi-static: a stop closes near the peak of the
force that drives the body into it), convergence from the truth's own gamma."""
from __future__ import annotations

from typing import Dict

import numpy as np
import pytest

from caekf_sim import flags as fl
from caekf_sim.estimator import run_estimator
from caekf_sim.experiments import experiment_config, scenario_config
from caekf_sim.mechanism import Mechanism, contact_values
from caekf_sim.truth import contact_episodes, simulate

from mechanism_support import example_scenario

EXAMPLES = ("shuttle", "valve")
PRESETS = ("switched", "switched-highq-constrained")


@pytest.fixture(scope="module")
def runs() -> Dict[str, tuple]:
    out = {}
    for name in EXAMPLES:
        sc = example_scenario(name)
        tr, stats = simulate(sc, return_stats=True)
        out[name] = (sc, tr, stats)
    return out


@pytest.fixture(scope="module")
def estimates(runs) -> Dict[tuple, object]:
    """Each preset as the numpy presets define it (no gate) and as the C tools run it over the scenario
    (scenario_config: the innovation gate at 25 on)."""
    configs = {"numpy": experiment_config, "c-settings": None}
    return {(name, p, how): run_estimator(sc, make(p) if make else scenario_config(sc, p), tr.t, tr.u, tr.y,
                                          keep_P=False)
            for name, (sc, tr, _) in runs.items() for p in PRESETS for how, make in configs.items()}


def test_examples_fit_the_format():
    shuttle = Mechanism.from_scenario(example_scenario("shuttle"))
    valve = Mechanism.from_scenario(example_scenario("valve"))
    assert shuttle.nq >= 6 and shuttle.n_contacts == 2 and shuttle.n_inputs == 2
    assert valve.n_contacts == 1 and valve.contact_n[0] == 1.0 and -1 in (valve.contact_a[0], valve.contact_b[0])
    assert 1 in shuttle.sensor_kind and 1 in valve.sensor_kind  # velocity sensors too


def _peak_times(sc, mech: Mechanism, sign: float, t_end: float) -> np.ndarray:
    """Times where input 1 (the drive) is at its maximum (sign +1) or minimum (-1)."""
    f, ph = mech.input_freq[0], mech.input_phase[0]
    k = np.arange(-2, int(t_end * f) + 3)
    t = ((0.25 if sign > 0 else 0.75) + k - ph / (2 * np.pi)) / f
    return t[(t > 0) & (t < t_end)]


@pytest.mark.parametrize("name", EXAMPLES)
def test_contacts_close_at_the_force_peaks(runs, name):
    sc, tr, stats = runs[name]
    mech = Mechanism.from_scenario(sc)
    D = tr.deltas
    n_eps = 0
    for c in range(mech.n_contacts):
        eps = contact_episodes(tr.t, D[:, c], merge_gap=0.2)
        # The drive closes contact c with a positive force if the static response to it opens delta_c.
        sign = 1.0 if mech.B_c[c] @ np.linalg.solve(mech.K, mech.B_u[:, 0]) > 0 else -1.0
        peaks = _peak_times(sc, mech, sign, sc.t_end)
        assert len(eps) >= 3, (c, eps)
        for a, b in eps:  # every episode is around a peak of the drive force
            assert np.min(np.abs(peaks - 0.5 * (a + b))) < 0.1 / mech.input_freq[0], (c, a, b, peaks)
        n_eps += len(eps)
    assert stats.events >= 2 * n_eps  # every episode was opened and closed by located events
    if mech.n_contacts == 2:  # the shuttle's stops are on opposite sides: never both closed
        assert not np.any((D[:, 0] > 0) & (D[:, 1] > 0))


@pytest.mark.parametrize("name", EXAMPLES)
@pytest.mark.parametrize("preset", PRESETS)
@pytest.mark.parametrize("how", ["numpy", "c-settings"])
def test_reference_ekf_converges(runs, estimates, name, preset, how):
    sc, tr, _ = runs[name]
    res = estimates[(name, preset, how)]
    g = contact_values(sc, "gamma", Mechanism.from_scenario(sc).n_contacts)
    err = res.gammas[-1] / g - 1.0
    assert np.all(np.abs(err) < 0.01), err
    assert np.all(np.abs(res.gammas[0] / g - 1.0) > 0.2)  # it did start far off
    assert np.any(res.flags & fl.GAMMA_GATED) == (how == "c-settings")  # the gate held gamma at times


def test_each_gamma_is_frozen_while_its_contact_is_open(runs, estimates):
    sc, tr, _ = runs["shuttle"]
    res = estimates[("shuttle", "switched", "numpy")]
    D = tr.deltas
    for c in range(2):
        # Steps well away from contact c (truth open for 50 ms on both sides): gamma_c must not move.
        open_ = np.convolve((D[:, c] <= 0).astype(int), np.ones(101, dtype=int), mode="same") == 101
        moved = np.diff(res.gammas[:, c]) != 0
        assert open_.sum() > len(tr.t) // 3
        assert not np.any(moved & open_[1:])
        assert np.any(moved)


def test_paper_in_the_general_keys_is_the_paper(sc, truth):
    """paper.toml rewritten with the canonical keys and the chain spelled out runs bit for bit alike."""
    from caekf_sim import schema
    from caekf_sim.scenario import default_scenario_path, parse_flat, scenario_from_text

    lines = [f"{schema.canonical(k)} = {v}" for k, (_, v) in parse_flat(default_scenario_path().read_text()).items()]
    lines += [f"spring{i}_{e} = {b}" for i, pair in enumerate([(1, 0), (1, 2), (3, 4), (4, 0)], 1)
              for e, b in zip("ab", pair)]
    lines += ["bodies = 4", "springs = 4", "inputs = 1", "sensors = 2", "contacts = 1", "contact1_a = 2",
              "contact1_b = 3", "contact1_n = 1.5", "contact1_lambda = 0", "input1_body = 1", "sensor1_body = 1",
              "sensor2_body = 4", 'sensor1_kind = "position"', 'sensor2_kind = "position"']
    general = scenario_from_text("\n".join(lines), "general")
    assert not {line.split(" = ")[0] for line in lines} & set(schema.ALIASES)  # no paper name left
    n = 20000  # through the first contact episode
    cfg = experiment_config("switched")
    a = run_estimator(sc, cfg, truth.t[:n], truth.u[:n], truth.y[:n], keep_P=False)
    b = run_estimator(general, cfg, truth.t[:n], truth.u[:n], truth.y[:n], keep_P=False)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.flags, b.flags)
    np.testing.assert_array_equal(simulate(general.replace(t_end=15.0)).q, simulate(sc.replace(t_end=15.0)).q)


def test_a_second_contact_that_never_closes_changes_nothing(sc, truth):
    """Contact 2 far away: gamma_1 follows the paper's single-contact run, gamma_2 stays frozen."""
    two = sc.replace(contacts=2, contact2_a=1, contact2_b=0, contact2_gap=1.0, contact2_n=1.0, contact2_lambda=0.0,
                     contact2_gamma=1e6, contact2_gamma0=3e5, contact2_sigma_gamma0=1e5,
                     contact2_sigma_q_gamma=1e3, contact2_gamma_min=0.0)
    n = 20000
    for preset in ("switched", "switched-highq-constrained"):
        cfg = experiment_config(preset)
        one = run_estimator(sc, cfg, truth.t[:n], truth.u[:n], truth.y[:n], keep_P=True)
        res = run_estimator(two, cfg, truth.t[:n], truth.u[:n], truth.y[:n], keep_P=True)
        np.testing.assert_allclose(res.gammas[:, 0], one.gamma, rtol=1e-9)
        np.testing.assert_allclose(res.x[:, :8], one.x[:, :8], rtol=0, atol=1e-9 * np.abs(one.x[:, :8]).max())
        assert np.all(res.gammas[:, 1] == 3e5) and np.all(res.P[:, 9, 9] == 1e10)
        np.testing.assert_array_equal(res.flags & ~0x100, one.flags & ~0x100)  # GAMMA_FROZEN: always, for gamma_2
