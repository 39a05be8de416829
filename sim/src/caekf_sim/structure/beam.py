"""A clamped steel cantilever whose tip region hits a stop: the realistic example of a linear structure.

Euler-Bernoulli elements (Hermite cubics, consistent mass), two DOFs per node (transverse displacement y,
rotation y'), node 0 at the clamp (its DOFs removed), free DOF 2 (i - 1) is node i's y and 2 (i - 1) + 1 its
rotation. The stop sits at y = gap on the positive side of the node nearest `stop_at`: delta = y(stop) - gap.
A shaker pushes the node nearest `shaker_at` transversely, two accelerometers read y'' at the nodes nearest
`accelerometers_at`, and a strain gauge reads the top fibre's strain eps = -(thickness / 2) y'' at `strain_at`
(anywhere: interpolated inside its element). Damping is Rayleigh's, C = alpha M + beta K, with the modal
damping ratios zeta1, zeta2 of modes 1 and 2.

`reduce` keeps the first modes (the estimator's model, whose truncation is its realistic model error);
`draw_beam` draws a beam of the family. The truth simulation of any structure is truth.py's `simulate`.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable, Tuple

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from .files import Structure

Matrix = NDArray[np.float64]
SENSOR_KINDS = ("acceleration", "acceleration", "position")  # accelerometer 1, 2, strain gauge


@dataclass(frozen=True)
class BeamSpec:
    """A steel cantilever and its excitation (SI units: m, Pa, kg/m^3, N, Hz).

    The default beam, 400 x 25 x 5 mm, has f1 = 26.1 Hz (analytic 1.875104^2 / (2 pi L^2) sqrt(EI / rho A)).
    The stop 0.5 mm away at 0.9 L needs 4.66 N at mid-span to close statically. The shaker drives at 18 Hz
    (0.69 f1: near resonance, so a moderate force suffices; below it, so the contact, which stiffens the beam,
    detunes it away from resonance rather than onto it) with 5.5 N (1.18 times the closing force: the linear
    response would overshoot the gap about 2.3 times). gamma = 1e8 N/m^1.5 is a steel sphere of a few mm on
    a flat. The tip then hits the stop once every forcing cycle (contact 1 to 2 ms) with penetrations of 25 to
    55 micrometres, on a periodic orbit (ten forcing cycles long), so that the truth converges with its
    substeps; stronger forcing (7 N, or 6 N at 16 Hz) gives an irregular response whose runs at different
    substeps drift apart after a few impacts. tests/test_structure_beam.py measures these numbers."""

    length: float = 0.4
    width: float = 0.025
    thickness: float = 0.005
    E: float = 210e9
    rho: float = 7850.0
    elements: int = 40
    stop_at: float = 0.9
    gap: float = 0.5e-3
    gamma: float = 1e8
    n: float = 1.5
    zeta1: float = 0.01
    zeta2: float = 0.01
    shaker_at: float = 0.5
    accelerometers_at: Tuple[float, float] = (0.6, 1.0)
    strain_at: float = 0.1
    force_amp: float = 5.5
    force_freq: float = 18.0
    preload: float = 0.0  # static shaker force added to the sine [N]

    @property
    def EI(self) -> float:
        return self.E * self.width * self.thickness**3 / 12.0

    @property
    def rho_A(self) -> float:
        return self.rho * self.width * self.thickness

    def force(self) -> Callable[[Matrix], Matrix]:
        """The shaker's u(t) = preload + force_amp sin(2 pi force_freq t), as (len(t), 1)."""
        def u(t: Matrix) -> Matrix:
            return (self.preload + self.force_amp * np.sin(2.0 * math.pi * self.force_freq * t))[:, None]
        return u


@dataclass(frozen=True, eq=False)
class FullInfo:
    """Where things are in the full model: node positions x (0..elements, x[0] = 0 the clamp), the free-DOF
    index of the stop's, the shaker's and the accelerometers' y, the strain gauge's element and local
    coordinate xi in [0, 1], the sensors' kinds (H's rows), all natural frequencies omega [rad/s] and
    Rayleigh's (alpha, beta)."""

    x: Matrix
    stop_dof: int
    shaker_dof: int
    accelerometer_dofs: Tuple[int, int]
    strain_element: int
    strain_xi: float
    sensor_kinds: Tuple[str, ...]
    omega: Matrix
    rayleigh: Tuple[float, float]


def element_matrices(EI: float, rho_A: float, le: float) -> Tuple[Matrix, Matrix]:
    """Stiffness and consistent mass of a Hermite-cubic element, DOFs (y1, y1', y2, y2')."""
    k = EI / le**3 * np.array([[12, 6 * le, -12, 6 * le],
                               [6 * le, 4 * le**2, -6 * le, 2 * le**2],
                               [-12, -6 * le, 12, -6 * le],
                               [6 * le, 2 * le**2, -6 * le, 4 * le**2]])
    m = rho_A * le / 420 * np.array([[156, 22 * le, 54, -13 * le],
                                     [22 * le, 4 * le**2, 13 * le, -3 * le**2],
                                     [54, 13 * le, 156, -22 * le],
                                     [-13 * le, -3 * le**2, -22 * le, 4 * le**2]])
    return k, m


def stiffness_and_mass(spec: BeamSpec) -> Tuple[Matrix, Matrix]:
    """K and M of the free DOFs (the clamp's two removed)."""
    ne = spec.elements
    k, m = element_matrices(spec.EI, spec.rho_A, spec.length / ne)
    K = np.zeros((2 * ne + 2, 2 * ne + 2))
    M = np.zeros_like(K)
    for e in range(ne):
        K[2 * e:2 * e + 4, 2 * e:2 * e + 4] += k
        M[2 * e:2 * e + 4, 2 * e:2 * e + 4] += m
    return K[2:, 2:], M[2:, 2:]


def node_at(spec: BeamSpec, fraction: float) -> int:
    """The node nearest `fraction` of the length; the clamp (node 0) cannot carry anything."""
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"position {fraction} of the length: must be in (0, 1]")
    return max(1, int(round(fraction * spec.elements)))


def y_dof(node: int) -> int:
    """The free-DOF index of node's transverse displacement."""
    return 2 * (node - 1)


def strain_row(spec: BeamSpec) -> Tuple[Matrix, int, float]:
    """The top fibre's strain -(thickness / 2) y''(x) at x = strain_at L as a row over the free DOFs, with the
    element and its local coordinate xi (a node is taken as the start of the element to its right)."""
    if not 0.0 <= spec.strain_at <= 1.0:
        raise ValueError(f"strain_at {spec.strain_at}: must be in [0, 1]")
    ne = spec.elements
    le = spec.length / ne
    e = min(int(math.floor(spec.strain_at * ne + 1e-9)), ne - 1)  # 1e-9: 0.1 * 40 is 4 nodes, not 3.99...
    xi = min(max(spec.strain_at * ne - e, 0.0), 1.0)
    # second derivatives in x of the Hermite shape functions N1..N4 at xi
    d2 = np.array([(12 * xi - 6) / le**2, (6 * xi - 4) / le, (6 - 12 * xi) / le**2, (6 * xi - 2) / le])
    row = np.zeros(2 * ne + 2)
    row[2 * e:2 * e + 4] = -0.5 * spec.thickness * d2
    return row[2:], e, xi


def rayleigh(omega1: float, omega2: float, zeta1: float, zeta2: float) -> Tuple[float, float]:
    """alpha, beta with zeta_i = alpha / (2 omega_i) + beta omega_i / 2 at modes 1 and 2."""
    a = np.array([[1 / (2 * omega1), omega1 / 2], [1 / (2 * omega2), omega2 / 2]])
    alpha, beta = np.linalg.solve(a, [zeta1, zeta2])
    return float(alpha), float(beta)


def assemble(spec: BeamSpec) -> Tuple[Structure, FullInfo]:
    """The full model: M, K, Rayleigh C; Bu the shaker's y, W the stop's y, H accelerometers 1, 2 (their y:
    the scenario reads them as acceleration) and the strain gauge (position kind)."""
    K, M = stiffness_and_mass(spec)
    omega = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True))
    alpha, beta = rayleigh(float(omega[0]), float(omega[1]), spec.zeta1, spec.zeta2)
    dofs = K.shape[0]
    stop, shaker = y_dof(node_at(spec, spec.stop_at)), y_dof(node_at(spec, spec.shaker_at))
    acc = tuple(y_dof(node_at(spec, a)) for a in spec.accelerometers_at)
    strain, element, xi = strain_row(spec)
    unit = np.eye(dofs)
    H = np.vstack([unit[acc[0]], unit[acc[1]], strain])
    s = Structure(M=M, K=K, C=alpha * M + beta * K, Bu=unit[:, [shaker]], W=unit[:, [stop]], H=H)
    info = FullInfo(x=np.linspace(0.0, spec.length, spec.elements + 1), stop_dof=stop, shaker_dof=shaker,
                    accelerometer_dofs=(acc[0], acc[1]), strain_element=element, strain_xi=xi,
                    sensor_kinds=SENSOR_KINDS, omega=omega, rayleigh=(alpha, beta))
    return s, info


def reduce(structure: Structure, modes: int) -> Structure:
    """The first `modes` mass-normalised modes: M = I, K = diag(omega^2), C, W, Bu, H projected (q ~ Phi_r eta)."""
    if not 1 <= modes <= structure.dofs:
        raise ValueError(f"modes {modes}: must be in 1..{structure.dofs}")
    omega2, phi = scipy.linalg.eigh(structure.K, structure.M, subset_by_index=[0, modes - 1])
    return structure._project(phi, omega2)


def closing_force(structure: Structure, gap: float) -> float:
    """The static input (column 0 of Bu) that moves the first contact's w^T q by `gap`."""
    compliance = float(structure.W[:, 0] @ np.linalg.solve(structure.K, structure.Bu[:, 0]))
    return gap / compliance


def draw_beam(rng: np.random.Generator) -> Tuple[BeamSpec, int]:
    """A random beam of the family and the estimator's mode count (4..8); deterministic given rng.

    length U(0.25, 0.6) m, width U(15, 40) mm, thickness U(3, 8) mm, gap U(0.2, 2) mm, gamma log-uniform
    1e7..1e9 N/m^1.5. The excitation is scaled to the gap, so that every drawn beam reaches its stop: amplitude
    U(1.5, 3) times the closing force (the static shaker force that closes the gap), frequency U(0.3, 0.8) f1
    (a dynamic amplification 1.1 to 2.8 on top)."""
    length, width, thickness = rng.uniform(0.25, 0.6), rng.uniform(15e-3, 40e-3), rng.uniform(3e-3, 8e-3)
    gap, gamma = rng.uniform(0.2e-3, 2e-3), 10.0 ** rng.uniform(7.0, 9.0)
    modes = int(rng.integers(4, 9))
    over, ratio = rng.uniform(1.5, 3.0), rng.uniform(0.3, 0.8)
    spec = BeamSpec(length=length, width=width, thickness=thickness, gap=gap, gamma=gamma)
    s, info = assemble(spec)
    return dataclasses.replace(spec, force_amp=over * closing_force(s, gap),
                               force_freq=ratio * float(info.omega[0]) / (2 * math.pi)), modes
