"""Truth model sanity; expectations are derived from the model equations, not from a run."""
import math

import numpy as np
import pytest

from caekf_sim.model import Plant, StepSolver
from caekf_sim.truth import contact_episodes, read_truth_csv, simulate, write_truth_csv


def quasi_static_contact_window(sc, period_index: int):
    """Slow forcing: q2 ~ q1 ~ u/k1 and body 3 ~ 0, so contact iff u(t) > k1*gap."""
    thr = math.asin(sc.k1 * sc.gap / sc.u_amp)  # in (0, pi/2)
    w = 2 * math.pi * sc.u_freq
    # u = u_amp sin(w t + phase) > k1 gap  <=>  w t + phase in (thr, pi - thr) + 2 pi n
    n = period_index + math.ceil((sc.u_phase - thr) / (2 * math.pi))
    return ((thr + 2 * math.pi * n - sc.u_phase) / w, (math.pi - thr + 2 * math.pi * n - sc.u_phase) / w)


def quasi_static_max_penetration(sc) -> float:
    """Static balance at u = u_amp with the Hertz spring in series: bisection on delta."""
    compliance = 1 / sc.k12 + 1 / sc.k34 + 1 / sc.k4

    def f(d):
        fc = sc.gamma * d**1.5
        return (sc.u_amp - fc) / sc.k1 - fc * compliance - sc.gap - d

    lo, hi = 0.0, 1e-3
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) > 0 else (lo, mid)
    return lo


def test_time_grid_and_rest_start(sc, truth):
    n = sc.n_steps
    assert len(truth) == n
    np.testing.assert_allclose(truth.t, np.arange(1, n + 1) * sc.dt, rtol=1e-15)
    assert np.all(np.isfinite(truth.as_array()))
    # From rest, one sample later displacements are at most of order u dt^2 / m.
    assert np.max(np.abs(truth.q[0])) < 10 * sc.u_amp * sc.dt**2 / min(sc.m1, sc.m2, sc.m3, sc.m4)
    np.testing.assert_array_equal(truth.u, sc.u_amp * np.sin(2 * np.pi * sc.u_freq * truth.t + sc.u_phase))


def test_noise_free_measurements_are_the_positions(sc, truth):
    assert sc.noise_std == 0.0
    np.testing.assert_array_equal(truth.y, truth.q[:, [0, 3]])
    np.testing.assert_allclose(truth.delta, truth.q[:, 1] - truth.q[:, 2] - sc.gap, rtol=0, atol=1e-18)


def test_contact_episodes_follow_the_forcing(sc, truth):
    eps = contact_episodes(truth.t, truth.delta, merge_gap=0.1)
    n_periods = int(sc.t_end * sc.u_freq)
    assert len(eps) == n_periods
    for i, (a, b) in enumerate(eps):
        qa, qb = quasi_static_contact_window(sc, i)
        assert abs(a - qa) < 0.05 and abs(b - qb) < 0.05, (i, (a, b), (qa, qb))
    # Short bounces precede each settled episode (the bodies hit and separate a few times).
    raw = contact_episodes(truth.t, truth.delta)
    assert len(raw) > len(eps)


def test_max_penetration_near_quasi_static(sc, truth):
    d_qs = quasi_static_max_penetration(sc)
    assert truth.delta.max() == pytest.approx(d_qs, rel=0.05)


def _energy_budget(s):
    """(numerical dissipation per step, physical dissipation per step, penetrations) of a run."""
    tr = simulate(s, method="backward-euler")
    plant = Plant.from_scenario(s)
    q = np.vstack([np.zeros(4), tr.q])
    v = np.vstack([np.zeros(4), tr.v])
    d = np.clip(plant.penetration(q), 0, None)
    energy = (0.5 * np.einsum("ki,i,ki->k", v, plant.m, v)
              + 0.5 * np.einsum("ki,ij,kj->k", q, plant.K, q) + s.gamma * d**2.5 / 2.5)
    damping = s.dt * np.einsum("ki,ij,kj->k", tr.v, plant.C, tr.v)
    slack = s.dt * tr.u * tr.v[:, 0] - damping - np.diff(energy)
    return slack, damping, d, np.max(np.abs(energy))


def test_work_energy_inequality_of_backward_euler(sc):
    """BE is dissipative: E_k - E_{k-1} <= h (u_k v1_k - v_k^T C v_k) (convex Hertz potential),
    and its numerical dissipation shrinks like O(h). One substep per sample so every step is seen.
    """
    shares = []
    for dt in (1e-3, 1e-4):
        slack, damping, d, e_max = _energy_budget(sc.replace(truth_substeps=1, dt=dt, t_end=15.0))
        assert np.all(slack >= -1e-12 * e_max)
        assert np.any(d > 0)  # the check did cover contact
        shares.append(slack.sum() / damping.sum())
    assert shares[1] < 0.3 * shares[0]  # first order: ~0.1


def test_fast_loop_equals_plain_newton_loop(sc):
    """The float hot loop of the backward-Euler truth must give what StepSolver.solve gives step by step."""
    s = sc.replace(u_freq=0.5, t_end=2.0)  # contact within 2 s
    tr = simulate(s, method="backward-euler")
    assert tr.delta.max() > 0
    plant = Plant.from_scenario(s)
    h = s.dt / s.truth_substeps
    solver = StepSolver(plant, h, max_iter=50)
    q, v = np.zeros(4), np.zeros(4)
    qs = []
    for j in range(1, s.n_steps * s.truth_substeps + 1):
        q, v, _, ok = solver.solve(q, v, float(plant.force(j * h)), s.gamma)
        assert ok
        if j % s.truth_substeps == 0:
            qs.append(q)
    np.testing.assert_allclose(np.array(qs), tr.q, rtol=0, atol=1e-15)


def test_noise_is_seeded_and_has_the_requested_std(sc):
    s = sc.replace(t_end=2.0, noise_std=1e-6)
    a, b = simulate(s), simulate(s)
    np.testing.assert_array_equal(a.y, b.y)
    e = a.y - a.q[:, [0, 3]]
    assert np.std(e) == pytest.approx(1e-6, rel=0.05)
    c = simulate(s.replace(seed=s.seed + 1))
    assert not np.array_equal(a.y, c.y)


def test_csv_round_trip_is_bit_exact(tmp_path, sc):
    tr = simulate(sc.replace(t_end=0.5))
    p = tmp_path / "truth.csv"
    write_truth_csv(tr, p)
    header = p.read_text().splitlines()[0]
    assert header == "t,u,y1,y4,q1,q2,q3,q4,v1,v2,v3,v4,delta"
    back = read_truth_csv(p)
    np.testing.assert_array_equal(back.as_array(), tr.as_array())
