"""Local observability of the augmented model by the PBH test (paper Sec. 3.2, eq. 20).

Continuous-time augmented model (eq. 3):
    d/dt q = v,  d/dt v = M^-1 (-K q - C v + B_u u - b f_c(q, gamma)),  d/dt gamma = 0.
Its Jacobian at (q, gamma):
    A = [[0, I, 0], [-M^-1 (K + k_c b b^T), -M^-1 C, -M^-1 b delta^1.5], [0, 0, 0]].
The pair (A, H) is observable iff rank [A - lambda I; H] = n at every eigenvalue lambda of A.
To make a numerical rank meaningful we scale first: time by 1/omega (omega = highest
undamped frequency), positions by a length L, velocities by omega L, gamma by its value,
so every entry is O(1); rank is then counted with singular values > RANK_RTOL * sigma_max.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Sequence, Tuple

import numpy as np

from .model import B_CONTACT, Plant, contact_force
from .scenario import Scenario

RANK_RTOL = 1e-9
SENSOR_INDEX = {"q1": 0, "q2": 1, "q3": 2, "q4": 3}


def linearisation_gamma(sc: Scenario) -> float:
    """The stiffness the model is linearised at: the true contact1_gamma, or, for a recording's scenario that
    has no truth, the estimator's initial contact1_gamma0."""
    return float(sc.gamma) if not math.isnan(sc.gamma) else float(sc.gamma0)


def augmented_jacobian(plant: Plant, delta: float, gamma: float) -> np.ndarray:
    """A: continuous-time Jacobian of [q; v; gamma] at penetration delta (<= 0: no contact)."""
    _, kc, dfc_dg = contact_force(delta, gamma)
    minv = 1.0 / plant.m
    A = np.zeros((9, 9))
    A[:4, 4:8] = np.eye(4)
    A[4:8, :4] = -minv[:, None] * (plant.K + kc * np.outer(B_CONTACT, B_CONTACT))
    A[4:8, 4:8] = -minv[:, None] * plant.C
    A[4:8, 8] = -minv * B_CONTACT * dfc_dg
    return A


def output_matrix(sensors: Sequence[str]) -> np.ndarray:
    H = np.zeros((len(sensors), 9))
    for row, s in enumerate(sensors):
        H[row, SENSOR_INDEX[s]] = 1.0
    return H


def scaled(A: np.ndarray, H: np.ndarray, length: float, gamma: float) -> Tuple[np.ndarray, np.ndarray]:
    """Similarity-scale the states and time so that A and H are O(1) (rank is invariant)."""
    omega = float(np.sqrt(np.max(np.abs(np.linalg.eigvals(A[4:8, :4])))))
    d = np.r_[np.full(4, length), np.full(4, omega * length), gamma]
    As = (A * d[None, :] / d[:, None]) / omega
    Hs = H * d[None, :] / length
    return As, Hs


@dataclass(frozen=True)
class PbhRow:
    eigenvalue: complex  # of the scaled A (units of omega)
    rank: int
    sigma_min_rel: float  # smallest singular value / largest


@dataclass(frozen=True)
class PbhResult:
    case: str
    sensors: Tuple[str, ...]
    rows: List[PbhRow]
    n: int

    @property
    def observable(self) -> bool:
        return all(r.rank == self.n for r in self.rows)

    @property
    def deficient(self) -> List[PbhRow]:
        return [r for r in self.rows if r.rank < self.n]


def pbh(A: np.ndarray, H: np.ndarray, rtol: float = RANK_RTOL) -> List[PbhRow]:
    """Eq. (20): rank of [A - lambda I; H] at each (distinct) eigenvalue of A."""
    n = A.shape[0]
    rows: List[PbhRow] = []
    for lam in np.linalg.eigvals(A):
        if any(abs(lam - r.eigenvalue) <= 1e-9 * max(1.0, abs(lam)) for r in rows):
            continue  # repeated eigenvalue: same matrix
        pbh = np.vstack([A - lam * np.eye(n), H.astype(complex)])  # the PBH matrix of eq. (20)
        sv = np.linalg.svd(pbh, compute_uv=False)
        rank = int(np.sum(sv > rtol * sv[0]))
        rows.append(PbhRow(complex(lam), rank, float(sv[-1] / sv[0])))
    return sorted(rows, key=lambda r: (abs(r.eigenvalue), r.eigenvalue.imag))


def analyse(
    sc: Scenario,
    penetration: float = 2e-6,
    sensor_sets: Sequence[Sequence[str]] = (("q1", "q4"), ("q1",), ("q4",)),
) -> Dict[Tuple[str, Tuple[str, ...]], PbhResult]:
    """PBH test for contact active (delta = penetration) and inactive, per sensor set."""
    plant = Plant.from_scenario(sc)
    gamma = linearisation_gamma(sc)
    out = {}
    for case, delta in (("active", penetration), ("inactive", -penetration)):
        A = augmented_jacobian(plant, delta, gamma)
        for sensors in sensor_sets:
            As, Hs = scaled(A, output_matrix(sensors), penetration, gamma)
            out[(case, tuple(sensors))] = PbhResult(case, tuple(sensors), pbh(As, Hs), A.shape[0])
    return out


def format_report(results: Dict[Tuple[str, Tuple[str, ...]], PbhResult]) -> str:
    lines = []
    for (case, sensors), res in results.items():
        lines.append(f"contact {case}, sensors {'+'.join(sensors)}:")
        lines.append(f"  {'eigenvalue (x omega)':>28}  rank/{res.n}  sigma_min/sigma_max")
        for r in res.rows:
            lam = r.eigenvalue
            lines.append(f"  {lam.real:+13.6e}{lam.imag:+13.6e}j  {r.rank:>4}    {r.sigma_min_rel:.2e}")
        verdict = "OBSERVABLE" if res.observable else "UNOBSERVABLE"
        lines.append(f"  -> {verdict}")
        lines.append("")
    return "\n".join(lines)


def gamma_in_unobservable_subspace(sc: Scenario, penetration: float = 2e-6) -> float:
    """|gamma component| of the null vector of [A - 0 I; H] with contact inactive (1 = pure gamma)."""
    plant = Plant.from_scenario(sc)
    gamma = linearisation_gamma(sc)
    A = augmented_jacobian(plant, -penetration, gamma)
    As, Hs = scaled(A, output_matrix(("q1", "q4")), penetration, gamma)
    _, _, vh = np.linalg.svd(np.vstack([As, Hs]))
    return float(abs(vh[-1, 8]))
