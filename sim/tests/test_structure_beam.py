"""The cantilever example (caekf_sim.structure.beam) and the truth of a structure with contacts
(caekf_sim.structure.truth); expectations from beam theory, closed forms and independent root finding."""
from __future__ import annotations

import math
from typing import Tuple

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from caekf_sim.structure.beam import BeamSpec, FullInfo, assemble, closing_force, draw_beam, reduce
from caekf_sim.structure.files import Structure
from caekf_sim.structure.truth import (BeamTruth, energy, penetration, penetrations, secant_force,
                                       secant_penetration, simulate)

BETA_L = np.array([1.875104, 4.694091, 7.854757, 10.995541])  # clamped-free beam, beta_n L


@pytest.fixture(scope="module")
def beam() -> Tuple[BeamSpec, Structure, FullInfo]:
    spec = BeamSpec()
    s, info = assemble(spec)
    return spec, s, info


def tip_load_response(spec: BeamSpec, s: Structure, load: float) -> np.ndarray:
    tip = np.zeros(s.dofs)
    tip[2 * (spec.elements - 1)] = load
    return np.linalg.solve(s.K, tip)


def test_first_four_frequencies_match_beam_theory(beam: Tuple[BeamSpec, Structure, FullInfo]) -> None:
    spec, _, info = beam
    exact = BETA_L**2 / spec.length**2 * math.sqrt(spec.EI / spec.rho_A)
    np.testing.assert_allclose(info.omega[:4], exact, rtol=5e-3)
    assert info.omega[0] / (2 * math.pi) == pytest.approx(26.11, abs=0.01)  # BeamSpec's docstring


def test_static_tip_deflection(beam: Tuple[BeamSpec, Structure, FullInfo]) -> None:
    spec, s, _ = beam
    q = tip_load_response(spec, s, 10.0)
    assert q[2 * (spec.elements - 1)] == pytest.approx(10.0 * spec.length**3 / (3 * spec.EI), rel=1e-6)


@pytest.mark.parametrize("strain_at,rtol", [(0.1, 1e-6), (0.1125, 1e-2), (0.537, 1e-2), (1.0, 1e-6)])
def test_strain_row_under_tip_load(strain_at: float, rtol: float) -> None:
    """Top fibre, y up: a tip load P > 0 bends the beam concave up, so the top is in compression,
    eps = -(t/2) P (L - x) / EI. At the tip the moment, and so the strain, is zero."""
    spec = BeamSpec(strain_at=strain_at)
    s, info = assemble(spec)
    eps = s.H[2] @ tip_load_response(spec, s, 10.0)
    x = strain_at * spec.length
    expected = -0.5 * spec.thickness * 10.0 * (spec.length - x) / spec.EI
    if strain_at == 1.0:
        assert abs(eps) < 1e-12
    else:
        assert eps == pytest.approx(expected, rel=rtol)
    assert info.sensor_kinds == ("acceleration", "acceleration", "position")


def test_structure_places_stop_shaker_and_accelerometers(beam: Tuple[BeamSpec, Structure, FullInfo]) -> None:
    spec, s, info = beam
    nodes = np.array([info.stop_dof, info.shaker_dof, *info.accelerometer_dofs]) // 2 + 1
    np.testing.assert_array_equal(nodes, [36, 20, 24, 40])
    # positions between nodes snap to the nearest
    _, odd_info = assemble(BeamSpec(elements=10, stop_at=0.87, shaker_at=0.44, accelerometers_at=(0.66, 0.96)))
    odd_nodes = np.array([odd_info.stop_dof, odd_info.shaker_dof, *odd_info.accelerometer_dofs]) // 2 + 1
    np.testing.assert_array_equal(odd_nodes, [9, 4, 7, 10])
    assert s.W[:, 0] @ np.ones(s.dofs) == 1.0 and s.W[info.stop_dof, 0] == 1.0
    assert s.Bu[info.shaker_dof, 0] == 1.0 and s.H[1, info.accelerometer_dofs[1]] == 1.0
    # Rayleigh: modes 1 and 2 get their damping ratios
    modal, _ = s.modal()
    zeta = np.diag(modal.C)[:2] / (2 * info.omega[:2])
    np.testing.assert_allclose(zeta, [spec.zeta1, spec.zeta2], rtol=1e-9)


def test_reduce_keeps_modes_and_all_modes_keep_compliance(beam: Tuple[BeamSpec, Structure, FullInfo]) -> None:
    _, s, info = beam
    r = reduce(s, 5)
    assert r.dofs == 5 and r.diagonal_mass() and (r.contacts, r.inputs, r.sensors) == (1, 1, 3)
    # 1e-7: the low eigenvalues of (K, M) are only that accurate, K's condition being (omega_80 / omega_1)^2 ~ 1e9
    np.testing.assert_allclose(np.sqrt(np.diag(r.K)), info.omega[:5], rtol=1e-7)
    np.testing.assert_array_equal(r.M, np.eye(5))
    # the reduced contact moves as the full model's modes do: per-mode participation w^T phi_i
    _, phi = scipy.linalg.eigh(s.K, s.M, subset_by_index=[0, 4])
    np.testing.assert_allclose(np.abs(r.W[:, 0]), np.abs(phi.T @ s.W[:, 0]), rtol=1e-10)
    full = float(s.W[:, 0] @ np.linalg.solve(s.K, s.W[:, 0]))
    complete = reduce(s, s.dofs)
    assert float(complete.W[:, 0] @ np.linalg.solve(complete.K, complete.W[:, 0])) == pytest.approx(full, rel=1e-9)
    truncated = float(r.W[:, 0] @ np.linalg.solve(r.K, r.W[:, 0]))
    assert 0.99 * full < truncated < full  # the model error the estimator lives with: small, one-sided


def modal_sine_response(s: Structure, amp: float, freq: float, t: np.ndarray) -> np.ndarray:
    """q(t) from rest under u = amp sin(2 pi freq t), mode by mode (Rayleigh C is diagonal in modes)."""
    omega2, phi = scipy.linalg.eigh(s.K, s.M)
    c = np.diag(phi.T @ s.C @ phi)
    p = amp * (phi.T @ s.Bu[:, 0])
    w = 2 * math.pi * freq
    P = p / (omega2 - w * w + 1j * c * w)  # particular solution Im(P e^{iwt})
    disc = np.sqrt((c * c - 4 * omega2).astype(complex))
    s2 = (-c - disc) / 2
    s1 = omega2 / s2  # s1 s2 = omega^2, without the cancellation of -c + disc for overdamped modes
    eta0, deta0 = P.imag, w * P.real
    A = (s2 * eta0 - deta0) / (s1 - s2)
    B = -eta0 - A
    tt = t[:, None]
    eta = (P[None, :] * np.exp(1j * w * tt)).imag + (A * np.exp(s1 * tt) + B * np.exp(s2 * tt)).real
    return np.asarray(eta @ phi.T)


def test_truth_without_contact_matches_modal_closed_form(beam: Tuple[BeamSpec, Structure, FullInfo]) -> None:
    spec, s, _ = beam
    truth = simulate(s, 1.0, spec.gamma, spec.n, spec.force(), 1e-3, 0.1, 400)
    exact = modal_sine_response(s, spec.force_amp, spec.force_freq, truth.t)
    assert not truth.f.any()
    assert np.max(np.abs(truth.q - exact)) < 1e-6 * np.max(np.abs(exact))


def test_preload_settles_on_static_contact_balance() -> None:
    spec = BeamSpec(zeta1=0.3, zeta2=0.3)
    s, _ = assemble(spec)
    load = 3.0 * closing_force(s, spec.gap)
    truth = simulate(s, spec.gap, spec.gamma, spec.n, lambda t: np.full((len(t), 1), load), 1e-3, 3.0, 2)
    w, b = s.W[:, 0], s.Bu[:, 0]
    open_gap = load * float(w @ np.linalg.solve(s.K, b)) - spec.gap  # penetration without the contact
    compliance = float(w @ np.linalg.solve(s.K, w))
    delta = scipy.optimize.brentq(lambda d: d + compliance * spec.gamma * d**spec.n - open_gap, 0.0, open_gap,
                                  xtol=1e-20, rtol=1e-15)
    assert truth.delta[-1, 0] == pytest.approx(delta, rel=1e-6)
    assert truth.f[-1, 0] == pytest.approx(spec.gamma * delta**spec.n, rel=1e-6)
    sampled = simulate(s, spec.gap, spec.gamma, spec.n, np.full(3001, load), 1e-3, 3.0, 2)  # samples, not u(t)
    np.testing.assert_array_equal(sampled.q, truth.q)
    with pytest.raises(ValueError, match="3000 samples, need 3001"):
        simulate(s, spec.gap, spec.gamma, spec.n, np.full(3000, load), 1e-3, 3.0, 2)


@pytest.fixture(scope="module")
def default_run(beam: Tuple[BeamSpec, Structure, FullInfo]) -> BeamTruth:
    spec, s, info = beam
    return simulate(s, spec.gap, spec.gamma, spec.n, spec.force(), 1e-3, 4.0, 10, kinds=info.sensor_kinds)


def test_default_beam_hits_the_stop_every_cycle(beam: Tuple[BeamSpec, Structure, FullInfo],
                                                 default_run: BeamTruth) -> None:
    """BeamSpec's docstring: a hit every forcing cycle, 25 to 55 micrometres, contact 1 to 2 ms."""
    spec = beam[0]
    cycle = np.floor(default_run.t * spec.force_freq).astype(int)
    peaks = np.array([default_run.delta[cycle == k, 0].max() for k in range(10, cycle.max())])  # after 10 cycles
    assert np.all(peaks > 20e-6) and np.all(peaks < 60e-6)
    closed = np.r_[0, (default_run.f[:, 0] > 0).astype(int), 0]
    lengths = np.diff(np.flatnonzero(np.diff(closed)))[::2]  # samples per contact
    assert set(lengths) <= {1, 2} and len(lengths) >= len(peaks)


def test_contact_force_law_and_equation_of_motion(beam: Tuple[BeamSpec, Structure, FullInfo],
                                                   default_run: BeamTruth) -> None:
    spec, s, _ = beam
    tr = default_run
    assert np.all(tr.f >= 0.0) and np.any(tr.f > 0.0)
    closed = tr.delta > 0
    np.testing.assert_allclose(tr.f[closed], spec.gamma * tr.delta[closed] ** spec.n, rtol=1e-9)
    assert not tr.f[~closed].any()
    residual = tr.a @ s.M + tr.v @ s.C + tr.q @ s.K + tr.f @ s.W.T - tr.u @ s.Bu.T
    assert np.max(np.abs(residual)) < 1e-9 * np.max(np.abs(tr.f))
    np.testing.assert_allclose(tr.y, np.column_stack([tr.a @ s.H[0], tr.a @ s.H[1], tr.q @ s.H[2]]), rtol=1e-12)
    np.testing.assert_allclose(tr.u[:, 0], spec.force()(tr.t)[:, 0], rtol=1e-12, atol=1e-12)


def free_swing(spec: BeamSpec, s: Structure, info: FullInfo) -> Tuple[Structure, np.ndarray]:
    """The beam without damping, and a start in mode 1 whose stop would swing 3 gaps out."""
    free = Structure(M=s.M, K=s.K, C=np.zeros_like(s.K), Bu=s.Bu, W=s.W, H=s.H)
    _, phi = scipy.linalg.eigh(s.K, s.M, subset_by_index=[0, 0])
    v0 = phi[:, 0] * 3 * spec.gap * info.omega[0] / abs(phi[info.stop_dof, 0])
    return free, np.concatenate([np.zeros(s.dofs), v0])


@pytest.mark.parametrize("gamma,substeps", [(1e8, 10), (1e9, 2)])
def test_energy_is_kept_without_input_or_damping(beam: Tuple[BeamSpec, Structure, FullInfo], gamma: float,
                                                 substeps: int) -> None:
    """Secant rule: exact energy balance, also for a contact shorter than a substep (1e9, h = 0.5 ms). The
    1e-7: rounding; the plain endpoint rule misses by 1e-2 to without bound here (the next test)."""
    spec, s, info = beam
    free, x0 = free_swing(spec, s, info)
    for gap in (1.0, spec.gap):
        tr = simulate(free, gap, gamma, spec.n, np.zeros(1001), 1e-3, 1.0, substeps, x0=x0)
        e = energy(free, tr, gamma, spec.n)
        np.testing.assert_allclose(e, e[0], rtol=1e-7)
        assert (gap == 1.0) == (not tr.f.any())


def test_endpoint_rule_loses_energy_only_when_resolved(beam: Tuple[BeamSpec, Structure, FullInfo]) -> None:
    """The plain trapezoidal contact term: with contacts of many substeps energy does not grow (the quadrature
    error of the contact's work, of either sign per step, mostly cancels); with coarse steps it is pumped up."""
    spec, s, info = beam
    free, x0 = free_swing(spec, s, info)
    fine = simulate(free, spec.gap, 1e8, spec.n, np.zeros(1001), 1e-3, 1.0, 50, x0=x0, rule="endpoint")
    e = energy(free, fine, 1e8, spec.n)
    assert np.max(e) < e[0] * (1 + 1e-7) and np.min(e) > 0.98 * e[0]
    coarse = simulate(free, spec.gap, 1e9, spec.n, np.zeros(1001), 1e-3, 1.0, 2, x0=x0, rule="endpoint")
    assert np.max(energy(free, coarse, 1e9, spec.n)) > 10 * e[0]


def test_contact_rules_converge_to_one_solution(beam: Tuple[BeamSpec, Structure, FullInfo]) -> None:
    """Both rules are second order: 10 and 20 substeps against 160 over the first impacts (0.1 s: later the
    impacts' sensitivity to their timing takes over), and the two rules agree at 160."""
    spec, s, info = beam
    runs = {(rule, k): simulate(s, spec.gap, spec.gamma, spec.n, spec.force(), 1e-3, 0.1, k, rule=rule)
            for rule in ("secant", "endpoint") for k in (10, 20, 160)}
    ref = runs["secant", 160].q[:, info.stop_dof]
    assert runs["secant", 160].f.any()
    scale = np.max(np.abs(ref))
    for rule in ("secant", "endpoint"):
        e10, e20 = (np.max(np.abs(runs[rule, k].q[:, info.stop_dof] - ref)) / scale for k in (10, 20))
        assert 3.0 < e10 / e20 < 5.0 and e20 < 1e-2
    assert np.max(np.abs(runs["endpoint", 160].q[:, info.stop_dof] - ref)) < 1e-4 * scale


@pytest.mark.parametrize("rule", ["secant", "endpoint"])
def test_several_contacts_match_one(beam: Tuple[BeamSpec, Structure, FullInfo], rule: str) -> None:
    """A second stop on the other side, never reached, changes nothing: the several-contact solve agrees."""
    spec, s, _ = beam
    both = Structure(M=s.M, K=s.K, C=s.C, Bu=s.Bu, W=np.hstack([s.W, -s.W]), H=s.H)
    one = simulate(s, spec.gap, spec.gamma, spec.n, spec.force(), 1e-3, 0.2, 5, rule=rule)
    two = simulate(both, [spec.gap, 1.0], [spec.gamma, 2 * spec.gamma], spec.n, spec.force(), 1e-3, 0.2, 5, rule=rule)
    assert one.f.any() and not two.f[:, 1].any()
    # 1e-9: the solves' tolerances (1e-12 of d against Newton's or brentq's 1e-15), grown over a few impacts
    np.testing.assert_allclose(two.q, one.q, rtol=0, atol=1e-9 * np.max(np.abs(one.q)))
    np.testing.assert_allclose(two.f[:, 0], one.f[:, 0], rtol=0, atol=1e-6 * np.max(one.f))


def test_contact_solves() -> None:
    for d, c, n in ((1e-5, 1e3, 1.5), (1e-3, 1e-2, 1.5), (2e-6, 5.0, 1.0), (1.0, 1e6, 2.5)):
        x = penetration(d, c, n)
        assert x + c * x**n == pytest.approx(d, rel=1e-14) and 0 < x <= d
    # secant: x + c / gamma (Phi(x) - Phi(x0)) / (x - x0) = d, Phi = gamma x_+^2.5 / 2.5; into, out of and
    # staying in contact, and the midpoint's stand-in at x = x0
    gamma = 1e8
    for d, x0, c in ((2e-5, -1e-5, 3e3), (-4e-5, 3e-5, 3e3), (3e-5, 2e-5, 3e4), (1e-5, 1e-5, 1e-12)):
        x = secant_penetration(d, x0, c, gamma, 1.5)
        phi = gamma / 2.5 * (max(x, 0) ** 2.5 - max(x0, 0) ** 2.5)
        fbar = phi / (x - x0) if abs(x - x0) > 1e-9 else gamma * x**1.5
        assert x + c / gamma * fbar == pytest.approx(d, rel=1e-9, abs=1e-20)
        assert secant_force(x, x0, gamma, 1.5) == pytest.approx(fbar, rel=1e-9)
    # near x0 (the midpoint's stand-in): against the quotient written without cancellation
    x0, r = 2e-5, 1e-6
    exact = gamma * x0**1.5 * math.expm1(2.5 * math.log1p(r)) / (2.5 * r)
    assert secant_force(x0 * (1 + r), x0, gamma, 1.5) == pytest.approx(exact, rel=1e-12)
    G = np.array([[2.0, 0.5], [0.5, 1.0]]) * 1e-3
    gamma = np.array([1e4, 3e4])
    x = penetrations(np.array([1e-2, -2e-3]), G, gamma, 1.5)
    np.testing.assert_allclose(x + G @ (gamma * np.maximum(x, 0) ** 1.5), [1e-2, -2e-3], atol=1e-16)


def test_draw_beam_is_deterministic_and_reaches_the_stop() -> None:
    draws = [draw_beam(np.random.default_rng(5)) for _ in range(2)]
    assert draws[0] == draws[1]
    for spec, modes in (draw_beam(np.random.default_rng(seed)) for seed in range(20)):
        s, info = assemble(spec)
        assert 4 <= modes <= 8 and 0.25 <= spec.length <= 0.6 and 0.2e-3 <= spec.gap <= 2e-3
        assert 1e7 <= spec.gamma <= 1e9 and 3e-3 <= spec.thickness <= 8e-3 and 15e-3 <= spec.width <= 40e-3
        assert 1.5 <= spec.force_amp / closing_force(s, spec.gap) <= 3.0
        assert 0.3 <= spec.force_freq * 2 * math.pi / info.omega[0] <= 0.8


def test_closing_force_closes_the_gap(beam: Tuple[BeamSpec, Structure, FullInfo]) -> None:
    spec, s, info = beam
    q = np.linalg.solve(s.K, s.Bu[:, 0] * closing_force(s, spec.gap))
    assert q[info.stop_dof] == pytest.approx(spec.gap, rel=1e-12)
    # cantilever with a point load P at a: y(x) = P a^2 (3 x - a) / (6 EI) beyond it
    a, x = 0.5 * spec.length, 0.9 * spec.length
    assert closing_force(s, spec.gap) == pytest.approx(spec.gap * 6 * spec.EI / (a * a * (3 * x - a)), rel=1e-9)
