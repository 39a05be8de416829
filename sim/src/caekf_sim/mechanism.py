"""A lumped mechanism on a line, as a scenario describes it (docs/mechanism.md).

Bodies 1..nq move on one axis (q_i: displacement from rest, v_i its velocity); body 0 is the ground
(q_0 = v_0 = 0). Springs/dampers join any two bodies or a body and the ground, input forces act on
bodies, sensors read a body's position or velocity, and contacts push two bodies (or a body and the
ground) apart with the law

    delta = q_a - q_b - gap,  ddelta = v_a - v_b,
    f = gamma * delta^n * (1 + lambda * ddelta)  for delta > 0 (clamped at f >= 0), else 0,

acting -f on body a and +f on body b. With body numbers 1-based in the file, every array here is
0-based and uses -1 for the ground.

`Mechanism.from_scenario(sc)` reads the canonical keys (`spring2_k`, `contact1_gap`, ...) or, for a
scenario that predates them, their paper aliases (`k12`, `gap`, ...); absent keys take the defaults
of the settings schema, which are the paper's chain. `sc` may be a `Scenario` or a plain {key: value} dict.

Or a linear structure given as matrices (docs/structure.md; `Mechanism.from_structure`, or from_scenario for a
scenario naming one): M q'' + C q' + K q + sum_c w_c f_c = B_u u, delta_c = w_c^T q - gap_c, sensor i reading
h_i^T of q, q' or q''. A line is the special case w_c = e_a - e_b, B_u's columns e_body, h_i = e_body, and the
model's code (model.py, estimator.py) reads only these vectors (Mechanism's B_c, B_load, H, H_acc and their
nonzero entries), never the ends.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .schema import ALIASES as SCHEMA_ALIASES
from .schema import SCHEMA, setting_of

if TYPE_CHECKING:
    from .structure.files import Structure

# Capacities of the format (the schema's [capacity] table).
MAX_BODIES = SCHEMA.capacity["bodies"]
MAX_SPRINGS = SCHEMA.capacity["springs"]
MAX_INPUTS = SCHEMA.capacity["inputs"]
MAX_SENSORS = SCHEMA.capacity["sensors"]
MAX_CONTACTS = SCHEMA.capacity["contacts"]
MAX_DOFS = SCHEMA.structure_dofs  # a structure's degrees of freedom (the schema's [structure] dofs)

# What a sensor reads (docs/sensors.md; the schema's sensor_kind, in its order).
SENSOR_KINDS: Tuple[str, ...] = tuple(SCHEMA.by_name("sensor_kind").values)
POSITION, VELOCITY, ACCELERATION, RELATIVE, LINK_FORCE = (SENSOR_KINDS.index(k) for k in (
    "position", "velocity", "acceleration", "relative", "link_force"))
# The sensor column's prefix per kind: y<body>, yv<body>, ya<body>, yr<body>_<ref>, yf<link>.
SENSOR_PREFIX = {POSITION: "y", VELOCITY: "yv", ACCELERATION: "ya", RELATIVE: "yr", LINK_FORCE: "yf"}

# What an input is (docs/mechanism.md "Base excitation"; the schema's input_kind, in its order): a force on its
# body [N], or the displacement of a link's ground end [m].
INPUT_KINDS: Tuple[str, ...] = tuple(SCHEMA.by_name("input_kind").values)
FORCE, BASE_DISPLACEMENT = (INPUT_KINDS.index(k) for k in ("force", "base_displacement"))

# Canonical key -> the paper's name for it (the schema's aliases, reversed).
ALIASES: Dict[str, str] = {canon: alias for alias, canon in SCHEMA_ALIASES.items()}


def default_of(key: str) -> Any:
    """The schema's default of a canonical key (None: required when in use, or not a setting)."""
    try:
        setting = setting_of(key)
    except KeyError:
        return None
    index = setting.keys.index(key) if key in setting.keys else 0
    d = setting.element_default(index)
    if isinstance(d, str):  # an enum's name or a build-relative value
        return setting.default_value(index=index)
    return d


class MechanismError(ValueError):
    """A mechanism that cannot be used; one line naming the key, its value and the rule."""

    def __init__(self, key: str, value: Any, rule: str) -> None:
        self.key = key
        super().__init__(f"{key} = {value}: {rule}")


def scenario_value(sc: Any, key: str) -> Any:
    """The value of a canonical key in a Scenario or dict: the key, else its paper alias, else the
    schema's default; MechanismError when none of them exists."""
    for k in (key, ALIASES.get(key)):
        if k is None:
            continue
        if isinstance(sc, Mapping):
            if k in sc:
                return sc[k]
        elif hasattr(sc, k):
            return getattr(sc, k)
    d = default_of(key)
    if d is not None:
        return d
    raise MechanismError(key, "(missing)", "required: it has no default")


def _count(sc: Any, key: str, lo: int, hi: int) -> int:
    v = scenario_value(sc, key)
    if not (float(v) == int(v) and lo <= int(v) <= hi):
        raise MechanismError(key, v, f"must be an integer in {lo}..{hi}")
    return int(v)


def _body(sc: Any, key: str, bodies: int, ground: bool) -> int:
    """0-based body index (-1 = ground) of a 1-based body-number key."""
    v = scenario_value(sc, key)
    lo = 0 if ground else 1
    if not (float(v) == int(v) and lo <= int(v) <= bodies):
        where = "0 (ground)" if ground else "1"
        raise MechanismError(key, v, f"must be a body number in {where}..{bodies} (bodies = {bodies})")
    return int(v) - 1


def _links(sc: Any, prefix: str, count: int, bodies: int) -> Tuple[list, list]:
    """0-based ends (a, b) of springs or contacts 1..count; -1 = ground, a != b."""
    ends: Tuple[list, list] = ([], [])
    for i in range(1, count + 1):
        a = _body(sc, f"{prefix}{i}_a", bodies, True)
        b = _body(sc, f"{prefix}{i}_b", bodies, True)
        if a == b:
            raise MechanismError(f"{prefix}{i}_b", b + 1, f"must differ from {prefix}{i}_a")
        ends[0].append(a)
        ends[1].append(b)
    return ends


def _real(sc: Any, key: str, lo: Optional[float] = None, strict: bool = False) -> float:
    v = float(scenario_value(sc, key))
    if not math.isfinite(v):
        raise MechanismError(key, v, "must be finite")
    if lo is not None and (v <= lo if strict else v < lo):
        raise MechanismError(key, format(v, "g"), f"must be {'>' if strict else '>='} {lo:g}")
    return v


def _excitation(sc: Any, key: str, lo: Optional[float] = None) -> float:
    """An input's sine (truth-only: a recording's scenario leaves it out, NaN, and the truth refuses that)."""
    v = float(scenario_value(sc, key))
    return v if math.isnan(v) else _real(sc, key, lo)


def _kind(sc: Any, key: str, kinds: Tuple[str, ...] = SENSOR_KINDS) -> int:
    """An enumerated key's number (SENSOR_KINDS, INPUT_KINDS), given by name or number."""
    v = scenario_value(sc, key)
    if isinstance(v, str):
        if v not in kinds:
            raise MechanismError(key, v, f"must be one of {', '.join(kinds)}")
        return kinds.index(v)
    if not (float(v) == int(v) and 0 <= int(v) < len(kinds)):
        raise MechanismError(key, v, f"must be one of {', '.join(kinds)}")
    return int(v)


def _inputs(sc: Any, ni: int, nq: int, spring_a: list, spring_b: list) -> Tuple[list, list, list]:
    """Each input's kind, body (0-based: a base displacement's is its link's end that is not the ground) and
    link (0-based, a base displacement's; -1 for a force)."""
    kinds, bodies, links = [], [], []
    for i in range(1, ni + 1):
        kind = _kind(sc, f"input{i}_kind", INPUT_KINDS)
        if kind == FORCE:
            kinds.append(kind)
            bodies.append(_body(sc, f"input{i}_body", nq, False))
            links.append(-1)
            continue
        key = f"input{i}_link"
        if not spring_a:
            raise MechanismError(f"input{i}_kind", INPUT_KINDS[kind], "needs a link (springs = 0)")
        link = _count(sc, key, 1, len(spring_a)) - 1
        a, b = spring_a[link], spring_b[link]
        if a >= 0 and b >= 0:
            raise MechanismError(key, link + 1, f"must name a link with one end on the ground (0): link {link + 1} "
                                 f"joins bodies {a + 1} and {b + 1}")
        if link in links:
            raise MechanismError(key, link + 1, f"link {link + 1} is moved by input{links.index(link) + 1} already")
        kinds.append(kind)
        bodies.append(a if a >= 0 else b)
        links.append(link)
    return kinds, bodies, links


def _pair_matrix(nq: int, a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Sum over links of w (e_a - e_b)(e_a - e_b)^T, ground (-1) omitted: K or C of the springs."""
    out = np.zeros((nq, nq))
    for ia, ib, wi in zip(a.tolist(), b.tolist(), w.tolist()):
        if ia >= 0:
            out[ia, ia] += wi
        if ib >= 0:
            out[ib, ib] += wi
        if ia >= 0 and ib >= 0:
            out[ia, ib] -= wi
            out[ib, ia] -= wi
    return out


def contact_law(delta: float, ddelta: float, gamma: float, n: float, lam: float
                ) -> Tuple[float, float, float, float]:
    """(f, df/ddelta, df/dddelta, df/dgamma) of one contact; all 0 while open (delta <= 0) or clamped.

    The clamp (no adhesion) acts when 1 + lambda ddelta <= 0, i.e. where f < 0 for any gamma > 0; a
    negative gamma (a diverged estimate) is not clamped, so the linearisation keeps its information.
    n = 1.5 and n = 1 are written out (sqrt, identity) so the paper's Hertz law keeps its bits."""
    if delta <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if n == 1.5:
        s = math.sqrt(delta)
        dn = delta * s
        fd = 1.5 * gamma * s
    elif n == 1.0:
        dn = delta
        fd = gamma
    else:
        dn = delta**n
        fd = n * gamma * delta ** (n - 1.0)
    if lam == 0.0:
        return gamma * dn, fd, 0.0, dn
    fac = 1.0 + lam * ddelta
    if fac <= 0.0:  # the damping term would pull: no adhesion
        return 0.0, 0.0, 0.0, 0.0
    return gamma * dn * fac, fd * fac, gamma * dn * lam, dn * fac


def law_derivatives(delta: float, ddelta: float, gamma: float, n: float, lam: float
                    ) -> Tuple[float, float, float, float, float, float]:
    """`contact_law` plus the derivatives with respect to the exponent and the damping: (f, df/ddelta,
    df/dddelta, df/dgamma, df/dn, df/dlambda); the gap's derivative is -df/ddelta."""
    f, fd, fr, fg = contact_law(delta, ddelta, gamma, n, lam)
    if delta <= 0.0 or 1.0 + lam * ddelta <= 0.0:
        return f, fd, fr, fg, 0.0, 0.0
    return f, fd, fr, fg, f * math.log(delta), gamma * delta**n * ddelta


# The contact-law parameters the filter can estimate besides gamma (settings contact{i}_estimate_<p>), in
# the order their states follow the gammas, contact by contact.
LAW_PARAMS = ("n", "lambda", "gap")


def law_layout(sc: Any, nc: int) -> Tuple[Tuple[int, str], ...]:
    """The estimated law parameters of a scenario or settings, in state order: (contact, name) with the
    contact 0-based; state 2 nq + nc + k is the k-th."""
    return tuple((c, p) for c in range(nc) for p in LAW_PARAMS
                 if int(float(scenario_value(sc, f"contact{c + 1}_estimate_{p}"))))


def law_column_names(layout: Sequence[Tuple[int, str]]) -> Tuple[str, ...]:
    """CSV column names of estimated law parameters, as caekf-replay writes them: `n`, `lambda`, `gap` for
    contact 1, `n2`, ... for contact 2."""
    return tuple(name if c == 0 else f"{name}{c + 1}" for c, name in layout)


# The mechanism parameters the filter can estimate (settings m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma > 0,
# docs/mechanism.md "Uncertain parameters and measured inputs"): their kinds, in the order their states follow
# the contact-law parameters (every mass, then every stiffness, then every damper, each by element index).
MECH_KINDS = ("m", "k", "c")


def mech_sigma_key(kind: str, elem: int) -> str:
    """The scenario key of the relative standard deviation of element `elem` (0-based) of `kind`."""
    return f"m{elem + 1}_sigma" if kind == "m" else f"spring{elem + 1}_{kind}_sigma"


def mech_value_key(kind: str, elem: int) -> str:
    """The scenario key of the value itself (m1, spring2_k, ...)."""
    return f"m{elem + 1}" if kind == "m" else f"spring{elem + 1}_{kind}"


def mech_layout(sc: Any) -> Tuple[Tuple[str, int, float], ...]:
    """The estimated mechanism parameters of a scenario or settings in state order (the C core's: masses,
    stiffnesses, dampers, each by element): (kind, element 0-based, relative sigma) for every sigma > 0."""
    out = []
    for kind in MECH_KINDS:
        count = int(float(scenario_value(sc, "bodies" if kind == "m" else "springs")))
        for e in range(count):
            sigma = _real(sc, mech_sigma_key(kind, e), 0.0)
            if sigma > 0.0:
                out.append((kind, e, sigma))
    return tuple(out)


def bias_layout(sc: Any) -> Tuple[Tuple[int, float], ...]:
    """The sensors whose offset is estimated (sensor{i}_bias_sigma > 0), in state order (after the mechanism's
    parameters): (sensor 0-based, sigma in the sensor's unit)."""
    count = int(float(scenario_value(sc, "sensors")))
    return tuple((i, s) for i in range(count) if (s := _real(sc, f"sensor{i + 1}_bias_sigma", 0.0)) > 0.0)


def bias_column_names(layout: Sequence[Tuple[int, float]]) -> Tuple[str, ...]:
    """Column names of the estimated offsets: sensor<i>_bias."""
    return tuple(f"sensor{i + 1}_bias" for i, _ in layout)


def sensor_sigmas(sc: Any, mech: "Mechanism") -> np.ndarray:
    """R's standard deviation per sensor (docs/sensors.md): sensor{i}_sigma, or 0 there for sigma_r (position,
    relative) or sigma_rv (velocity); acceleration and link-force sensors need their own."""
    out = []
    for i, kind in enumerate(mech.sensor_kind.tolist(), start=1):
        key = f"sensor{i}_sigma"
        s = float(scenario_value(sc, key))
        if not s > 0.0:
            if kind in (ACCELERATION, LINK_FORCE):
                raise MechanismError(key, s, f"must be > 0: sensor{i} reads {SENSOR_KINDS[kind]}")
            key = "sigma_rv" if kind == VELOCITY else "sigma_r"
            s = float(scenario_value(sc, key))
            if not s > 0.0:
                raise MechanismError(key, s, "R needs > 0 for every sensor of that kind")
        out.append(s)
    return np.array(out)


def mech_column_names(layout: Sequence[Tuple[str, int, float]]) -> Tuple[str, ...]:
    """Column names of estimated mechanism parameters: the value's own key (m1, spring2_k, spring3_c)."""
    return tuple(mech_value_key(kind, e) for kind, e, _ in layout)


def contact_forces(delta: np.ndarray, ddelta: np.ndarray, gamma: "np.ndarray | float", n: "np.ndarray | float",
                   lam: "np.ndarray | float") -> np.ndarray:
    """Vectorised contact force f (broadcast over any shape; the law of `contact_law`)."""
    d = np.clip(np.asarray(delta, dtype=float), 0.0, None)
    fac = 1.0 + np.asarray(lam) * ddelta
    return np.where((np.asarray(delta) > 0.0) & (fac > 0.0), gamma * d**n * fac, 0.0)


Direction = Tuple[Tuple[int, ...], Tuple[float, ...]]


def _direction(vec: np.ndarray) -> Direction:
    """The nonzero entries of a vector over the degrees of freedom, ascending: (indices, values)."""
    idx = np.flatnonzero(vec)
    return tuple(idx.tolist()), tuple(vec[idx].tolist())


def _ends(a: int, b: int) -> Direction:
    """e_a - e_b as a direction, end a first (ground, -1, omitted): a line's contact or a relative reading."""
    out = [(a, 1.0)] if a >= 0 else []
    if b >= 0:
        out.append((b, -1.0))
    return tuple(i for i, _ in out), tuple(w for _, w in out)


def along(d: Direction, x: Any) -> Any:
    """sum_k w_k x[i_k] over a direction (i, w), in its order from 0: a line's e_a - e_b gives x_a - x_b exactly
    (the ends' formula), a structure's w_c the terms of the C core's structure_dot in its order."""
    s = 0.0
    for i, w in zip(*d):
        s += w * x[i]
    return s


@dataclass(frozen=True, eq=False)
class Mechanism:
    """Bodies, springs/dampers, inputs, sensors and contacts; arrays are 0-based, -1 = ground.

    Or a structure given as matrices (`from_structure`, docs/structure.md): `structure` then holds its
    M (diagonal), K, C, B_u, W and H, and the line's ends are -1 (no springs). Either way the model's code reads
    the vectors derived here, never the ends: K, C, B_u, B_load, B_c (rows w_c: a line's e_a - e_b), H and
    H_acc (the sensors' rows), and their nonzero entries (contact_dirs, input_dirs, accel_dirs)."""

    m: np.ndarray  # (nq,) masses [kg]; a structure's diag(M)
    spring_a: np.ndarray  # (n_springs,) int
    spring_b: np.ndarray
    spring_k: np.ndarray  # [N/m]
    spring_c: np.ndarray  # [N s/m]
    input_body: np.ndarray  # (ni,) int
    input_amp: np.ndarray  # (ni,) truth excitation u_i = amp sin(2 pi freq t + phase) [N]
    input_freq: np.ndarray  # [Hz]
    input_phase: np.ndarray  # [rad]
    sensor_body: np.ndarray  # (ns,) int
    sensor_kind: np.ndarray  # (ns,) POSITION | VELOCITY | ACCELERATION | RELATIVE | LINK_FORCE
    contact_a: np.ndarray  # (nc,) int
    contact_b: np.ndarray
    contact_gap: np.ndarray  # [m]
    contact_n: np.ndarray  # exponent >= 1
    contact_lambda: np.ndarray  # Hunt-Crossley damping [s/m]
    sensor_ref: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # relative: 0-based, -1
    sensor_link: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # link force: 0-based
    # FORCE | BASE_DISPLACEMENT per input, and a base displacement's link (0-based; -1 for a force). A base
    # displacement u [m] moves its link's ground end: k (u - q_b) + c (du/dt - v_b) on the link's body, which
    # input_body holds (K and C hold the -k q_b, -c v_b parts; B_u and B_du the rest).
    input_kind: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    input_link: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    # A structure given as matrices with a diagonal M (from_structure), whose K, C, B_u, W and H replace the line's
    # (its bodies, links and ends: none); None for bodies on a line.
    structure: Optional["Structure"] = None
    # q_given = modal_basis @ q when from_structure took a structure to its modal basis (a non-diagonal M), else None
    modal_basis: Optional[np.ndarray] = None
    # derived
    K: np.ndarray = field(init=False)
    C: np.ndarray = field(init=False)
    # (nq, ni): input i's force per unit of u_i on column i: e_body for a force, k e_body for a base displacement
    B_u: np.ndarray = field(init=False)
    B_du: np.ndarray = field(init=False)  # (nq, ni): per unit of du_i/dt: 0, or c e_body for a base displacement
    # (nq, ni): where the force the step takes from input i acts (model.StepSolver.forces_at turns a base
    # displacement into its force): e_body on a line, a structure's B_u column
    B_load: np.ndarray = field(init=False)
    B_c: np.ndarray = field(init=False)  # (nc, nq): row c = w_c (a line's e_a - e_b); delta = B_c q - gap
    H: np.ndarray = field(init=False)  # (ns, 2 nq): y = H [q; v] (an acceleration's row: H_acc)
    H_acc: np.ndarray = field(init=False)  # (ns, nq): an acceleration sensor's row h (y = h^T q''), else 0
    # the nonzero entries of B_c's rows, B_load's columns and H_acc's rows: (indices, values) each; a line's
    # contact is (a, b) with (1, -1) in that order, ground omitted
    contact_dirs: Tuple[Direction, ...] = field(init=False)
    input_dirs: Tuple[Direction, ...] = field(init=False)
    accel_dirs: Tuple[Direction, ...] = field(init=False)
    # sizes: bodies, inputs, sensors, contacts
    nq: int = field(init=False)
    n_inputs: int = field(init=False)
    n_sensors: int = field(init=False)
    n_contacts: int = field(init=False)

    def __post_init__(self) -> None:
        nq = len(self.m)
        set_ = object.__setattr__
        for name, n in (("nq", nq), ("n_inputs", len(self.input_body)), ("n_sensors", len(self.sensor_body)),
                        ("n_contacts", len(self.contact_a))):
            set_(self, name, n)
        ni, ns = self.n_inputs, self.n_sensors
        if len(self.input_kind) != ni:  # a mechanism built without them: every input a force
            set_(self, "input_kind", np.full(ni, FORCE, dtype=np.int64))
            set_(self, "input_link", np.full(ni, -1, dtype=np.int64))
        if len(self.sensor_ref) != ns:  # a mechanism built without them: none relative, link 1
            set_(self, "sensor_ref", np.full(ns, -1, dtype=np.int64))
        if len(self.sensor_link) != ns:
            set_(self, "sensor_link", np.zeros(ns, dtype=np.int64))
        if self.structure is not None:
            self._derive_structure(self.structure)
        else:
            self._derive_line()
        set_(self, "contact_dirs", tuple(_direction(w) if self.structure is not None else
                                         _ends(int(a), int(b)) for w, a, b in
                                         zip(self.B_c, self.contact_a.tolist(), self.contact_b.tolist())))
        set_(self, "input_dirs", tuple(_direction(self.B_load[:, i]) for i in range(ni)))
        set_(self, "accel_dirs", tuple(_direction(h) for h in self.H_acc))

    def _derive_structure(self, st: "Structure") -> None:
        """K, C, B_u, B_c and the sensors' rows from a structure's matrices (its M diagonal, as m)."""
        set_ = object.__setattr__
        nq, ni = self.nq, self.n_inputs
        if st.M.shape != (nq, nq) or not st.diagonal_mass() or np.any(np.diag(st.M) != self.m):
            raise ValueError("Mechanism: m must be the structure's diagonal M (use Mechanism.from_structure)")
        set_(self, "K", np.array(st.K, dtype=float))
        set_(self, "C", np.array(st.C, dtype=float))
        set_(self, "B_u", np.array(st.Bu, dtype=float).reshape(nq, ni))
        set_(self, "B_du", np.zeros((nq, ni)))
        set_(self, "B_load", self.B_u)
        set_(self, "B_c", np.array(st.W, dtype=float).T.reshape(self.n_contacts, nq))
        kinds = self.sensor_kind.tolist()
        H = np.zeros((self.n_sensors, 2 * nq))
        H_acc = np.zeros((self.n_sensors, nq))
        for i, (h, k) in enumerate(zip(np.asarray(st.H, dtype=float), kinds)):
            if k == ACCELERATION:
                H_acc[i] = h
            else:
                H[i, nq * (k == VELOCITY) : nq * (1 + (k == VELOCITY))] = h
        set_(self, "H", H)
        set_(self, "H_acc", H_acc)

    def _derive_line(self) -> None:
        """K, C, B_u, B_c and the sensors' rows from the bodies, links and ends."""
        set_ = object.__setattr__
        nq, ni, ns = self.nq, self.n_inputs, self.n_sensors
        set_(self, "K", _pair_matrix(nq, self.spring_a, self.spring_b, self.spring_k))
        set_(self, "C", _pair_matrix(nq, self.spring_a, self.spring_b, self.spring_c))
        B_u = np.zeros((nq, ni))
        B_u[self.input_body, np.arange(ni)] = 1.0
        set_(self, "B_load", B_u.copy())
        B_du = np.zeros((nq, ni))
        for i in np.flatnonzero(self.input_kind == BASE_DISPLACEMENT).tolist():
            link = int(self.input_link[i])
            B_u[self.input_body[i], i] = self.spring_k[link]
            B_du[self.input_body[i], i] = self.spring_c[link]
        set_(self, "B_u", B_u)
        set_(self, "B_du", B_du)
        B_c = np.zeros((len(self.contact_a), nq))
        for c, (ia, ib) in enumerate(zip(self.contact_a.tolist(), self.contact_b.tolist())):
            if ia >= 0:
                B_c[c, ia] += 1.0
            if ib >= 0:
                B_c[c, ib] -= 1.0
        set_(self, "B_c", B_c)
        H = np.zeros((ns, 2 * nq))  # the sensors linear in [q; v]
        H_acc = np.zeros((ns, nq))
        for i, (b, k, r, link) in enumerate(zip(self.sensor_body.tolist(), self.sensor_kind.tolist(),
                                                self.sensor_ref.tolist(), self.sensor_link.tolist())):
            if k in (POSITION, VELOCITY):
                H[i, b + nq * k] = 1.0
            elif k == ACCELERATION:
                H_acc[i, b] = 1.0
            elif k == RELATIVE:
                H[i, b] = 1.0
                if r >= 0:
                    H[i, r] -= 1.0
            elif k == LINK_FORCE:
                a, bb = int(self.spring_a[link]), int(self.spring_b[link])
                for end, sign in ((a, 1.0), (bb, -1.0)):
                    if end >= 0:
                        H[i, end] += sign * self.spring_k[link]
                        H[i, nq + end] += sign * self.spring_c[link]
        set_(self, "H", H)
        set_(self, "H_acc", H_acc)

    def with_values(self, m: np.ndarray, spring_k: np.ndarray, spring_c: np.ndarray) -> "Mechanism":
        """The same mechanism with other masses, stiffnesses and dampers (K, C derived again)."""
        return dataclasses.replace(self, m=np.asarray(m, dtype=float), spring_k=np.asarray(spring_k, dtype=float),
                                   spring_c=np.asarray(spring_c, dtype=float))

    @property
    def M(self) -> np.ndarray:
        return np.diag(self.m)

    @property
    def has_base_inputs(self) -> bool:
        """Whether an input is a base displacement (input{i}_kind)."""
        return bool(np.any(self.input_kind == BASE_DISPLACEMENT))

    def base_ends(self, u: np.ndarray, du: Optional[np.ndarray] = None) -> Tuple[np.ndarray, np.ndarray]:
        """Every link's ground end, displacement and rate (..., n_springs): a base input's u and du/dt on the
        link it moves, 0 elsewhere (du None: 0)."""
        u = np.asarray(u, dtype=float)
        shape = u.shape[:-1] + (len(self.spring_k),)
        gq, gv = np.zeros(shape), np.zeros(shape)
        for i in np.flatnonzero(self.input_kind == BASE_DISPLACEMENT).tolist():
            gq[..., int(self.input_link[i])] = u[..., i]
            if du is not None:
                gv[..., int(self.input_link[i])] = np.asarray(du, dtype=float)[..., i]
        return gq, gv

    @property
    def is_structure(self) -> bool:
        """Whether this is a structure given as matrices (from_structure), not bodies on a line."""
        return self.structure is not None

    @property
    def contacts(self) -> Tuple[Tuple[int, int, float, float, float], ...]:
        """(a, b, gap, n, lambda) per contact of bodies on a line as Python scalars (the line's truth); a
        structure's contacts have no ends (contact_laws)."""
        if self.structure is not None:
            raise ValueError("a structure's contacts act along their w_c, not between two bodies: use contact_laws")
        return tuple(zip(self.contact_a.tolist(), self.contact_b.tolist(), self.contact_gap.tolist(),
                         self.contact_n.tolist(), self.contact_lambda.tolist()))

    @property
    def contact_laws(self) -> Tuple[Tuple[Direction, float, float, float], ...]:
        """(direction, gap, n, lambda) per contact as Python scalars (the step's hot loop): delta =
        along(direction, q) - gap, its rate along(direction, v)."""
        return tuple(zip(self.contact_dirs, self.contact_gap.tolist(), self.contact_n.tolist(),
                         self.contact_lambda.tolist()))

    # ---- construction -------------------------------------------------------------------
    @staticmethod
    def from_structure(structure: "Structure", sc: Any) -> "Mechanism":
        """A structure given as matrices (docs/structure.md) with the scenario's counts (checked against the
        matrices), sensor kinds, contact laws and inputs' sines. A non-diagonal M is first taken to its modal
        basis (Structure.modal(), as binding.Estimator does: the same model in q = modal_basis @ eta). What the
        C core refuses for a structure is refused here by key: a line's sensor kind, a base displacement, an
        uncertain mass or link."""
        basis = None
        if not structure.diagonal_mass():
            structure, basis = structure.modal()
        if not 1 <= structure.dofs <= MAX_DOFS:
            raise MechanismError("structure", f"{structure.dofs} dofs", f"must have 1..{MAX_DOFS} degrees of freedom")
        counts = {}
        for key, lo, hi, have, where in (("inputs", 0, MAX_INPUTS, structure.inputs, "B_u's columns"),
                                         ("sensors", 1, MAX_SENSORS, structure.sensors, "H's rows"),
                                         ("contacts", 0, MAX_CONTACTS, structure.contacts, "W's columns")):
            counts[key] = _count(sc, key, lo, hi)
            if counts[key] != have:
                raise MechanismError(key, counts[key], f"the structure has {have} ({where})")
        ni, ns, nc = counts["inputs"], counts["sensors"], counts["contacts"]
        for i in range(1, ni + 1):
            if _kind(sc, f"input{i}_kind", INPUT_KINDS) != FORCE:
                raise MechanismError(f"input{i}_kind", scenario_value(sc, f"input{i}_kind"),
                                     "a structure's input is a force along its B_u column")
        kinds = [_kind(sc, f"sensor{i}_kind") for i in range(1, ns + 1)]
        for i, kind in enumerate(kinds, start=1):
            if kind not in (POSITION, VELOCITY, ACCELERATION):
                raise MechanismError(f"sensor{i}_kind", SENSOR_KINDS[kind],
                                     "a structure's sensor reads position, velocity or acceleration")
        for what, e, sigma in mech_layout(sc):
            raise MechanismError(mech_sigma_key(what, e), sigma, "a structure's masses and links are not estimated")
        ints = lambda xs: np.array(xs, dtype=np.int64)  # noqa: E731
        reals = lambda xs: np.array(xs, dtype=float)  # noqa: E731
        none = np.full(0, -1, dtype=np.int64)
        return Mechanism(
            m=np.diag(structure.M).copy(), spring_a=none, spring_b=none, spring_k=reals([]), spring_c=reals([]),
            input_body=np.full(ni, -1, dtype=np.int64),
            input_amp=reals([_excitation(sc, f"input{i}_amp") for i in range(1, ni + 1)]),
            input_freq=reals([_excitation(sc, f"input{i}_freq", 0.0) for i in range(1, ni + 1)]),
            input_phase=reals([_excitation(sc, f"input{i}_phase") for i in range(1, ni + 1)]),
            input_kind=np.full(ni, FORCE, dtype=np.int64), input_link=np.full(ni, -1, dtype=np.int64),
            sensor_body=np.full(ns, -1, dtype=np.int64), sensor_kind=ints(kinds),
            sensor_ref=np.full(ns, -1, dtype=np.int64), sensor_link=np.zeros(ns, dtype=np.int64),
            contact_a=np.full(nc, -1, dtype=np.int64), contact_b=np.full(nc, -1, dtype=np.int64),
            contact_gap=reals([_real(sc, f"contact{i}_gap") for i in range(1, nc + 1)]),
            contact_n=reals([_real(sc, f"contact{i}_n", 1.0) for i in range(1, nc + 1)]),
            contact_lambda=reals([_real(sc, f"contact{i}_lambda", 0.0) for i in range(1, nc + 1)]),
            structure=structure, modal_basis=basis)

    @staticmethod
    def from_scenario(sc: Any) -> "Mechanism":
        """Read and check the mechanism keys of a Scenario or dict (docs/mechanism.md); a scenario that names a
        structure (its `structure`, docs/structure.md) gives that structure (from_structure)."""
        structure = getattr(sc, "structure", None) if not isinstance(sc, Mapping) else sc.get("structure")
        if structure is not None:
            return Mechanism.from_structure(structure, sc)
        nq = _count(sc, "bodies", 1, MAX_BODIES)
        m = np.array([_real(sc, f"m{i}", 0.0, strict=True) for i in range(1, nq + 1)])
        n_springs = _count(sc, "springs", 0, MAX_SPRINGS)
        sa, sb = _links(sc, "spring", n_springs, nq)
        sk = [_real(sc, f"spring{i}_k", 0.0) for i in range(1, n_springs + 1)]
        scc = [_real(sc, f"spring{i}_c", 0.0) for i in range(1, n_springs + 1)]
        ni = _count(sc, "inputs", 0, MAX_INPUTS)
        ik, ib, il = _inputs(sc, ni, nq, sa, sb)
        amp = [_excitation(sc, f"input{i}_amp") for i in range(1, ni + 1)]
        freq = [_excitation(sc, f"input{i}_freq", 0.0) for i in range(1, ni + 1)]
        phase = [_excitation(sc, f"input{i}_phase") for i in range(1, ni + 1)]
        ns = _count(sc, "sensors", 1, MAX_SENSORS)
        sens: List[Tuple[int, int, int, int]] = []
        for i in range(1, ns + 1):
            body, kind = _body(sc, f"sensor{i}_body", nq, False), _kind(sc, f"sensor{i}_kind")
            ref = _body(sc, f"sensor{i}_ref", nq, True) if kind == RELATIVE else -1
            if kind == RELATIVE and ref == body:
                raise MechanismError(f"sensor{i}_ref", ref + 1, f"must differ from sensor{i}_body")
            link = 0
            if kind == LINK_FORCE:
                if n_springs == 0:
                    raise MechanismError(f"sensor{i}_kind", "link_force", "needs a link (springs = 0)")
                link = _count(sc, f"sensor{i}_link", 1, n_springs) - 1
                body = -1  # a link force reads no one body
            s = (body, kind, ref, link)
            if s in sens:
                raise MechanismError(f"sensor{i}_body", body + 1, f"reads what sensor{sens.index(s) + 1} reads")
            sens.append(s)
        nc = _count(sc, "contacts", 0, MAX_CONTACTS)
        ca, cb = _links(sc, "contact", nc, nq)
        gap = [_real(sc, f"contact{i}_gap") for i in range(1, nc + 1)]
        n = [_real(sc, f"contact{i}_n", 1.0) for i in range(1, nc + 1)]
        lam = [_real(sc, f"contact{i}_lambda", 0.0) for i in range(1, nc + 1)]
        ints = lambda xs: np.array(xs, dtype=np.int64)  # noqa: E731
        reals = lambda xs: np.array(xs, dtype=float)  # noqa: E731
        return Mechanism(
            m=m, spring_a=ints(sa), spring_b=ints(sb), spring_k=reals(sk), spring_c=reals(scc),
            input_body=ints(ib), input_amp=reals(amp), input_freq=reals(freq), input_phase=reals(phase),
            input_kind=ints(ik), input_link=ints(il),
            sensor_body=ints([max(s[0], 0) for s in sens]), sensor_kind=ints([s[1] for s in sens]),
            sensor_ref=ints([s[2] for s in sens]), sensor_link=ints([s[3] for s in sens]),
            contact_a=ints(ca), contact_b=ints(cb), contact_gap=reals(gap), contact_n=reals(n),
            contact_lambda=reals(lam))

    # ---- kinematics ---------------------------------------------------------------------
    def penetrations(self, q: np.ndarray) -> np.ndarray:
        """delta of every contact, shape (..., nc), for a state row or an (N, nq) array of them."""
        q = np.asarray(q, dtype=float)
        cols = [along(d, _columns(q)) - g for d, g in zip(self.contact_dirs, self.contact_gap.tolist())]
        return np.stack(cols, axis=-1) if cols else np.zeros(q.shape[:-1] + (0,))

    def penetration_rates(self, v: np.ndarray) -> np.ndarray:
        """ddelta/dt of every contact, shape (..., nc)."""
        v = np.asarray(v, dtype=float)
        cols = [along(d, _columns(v)) for d in self.contact_dirs]
        return np.stack(cols, axis=-1) if cols else np.zeros(v.shape[:-1] + (0,))

    def penetration(self, q: np.ndarray) -> "np.ndarray | float":
        """delta of contact 1 (the paper's single contact)."""
        return self.penetrations(q)[..., 0]

    @property
    def gap(self) -> float:
        """Gap of contact 1 (the paper's single contact)."""
        return float(self.contact_gap[0])

    def forces(self, q: np.ndarray, v: np.ndarray, gamma: Sequence[float]) -> np.ndarray:
        """Contact forces f_c (..., nc) at states (q, v) with stiffnesses gamma (nc,)."""
        return contact_forces(self.penetrations(q), self.penetration_rates(v), np.asarray(gamma, dtype=float),
                              self.contact_n, self.contact_lambda)

    def accelerations(self, q: np.ndarray, v: np.ndarray, u: np.ndarray, gamma: "np.ndarray | Sequence[float]",
                      du: Optional[np.ndarray] = None) -> np.ndarray:
        """The bodies' accelerations (..., nq) at states (q, v) with inputs u (..., ni), their rates du (a base
        displacement's du/dt; None: 0) and stiffnesses gamma: M^-1 (B_u u + B_du du - K q - C v + B_c^T-signed
        contact forces: -f on a contact's body a, +f on b)."""
        q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
        f = -(q @ self.K.T) - v @ self.C.T + np.asarray(u, dtype=float).reshape(q.shape[:-1] + (-1,)) @ self.B_u.T
        if du is not None and self.has_base_inputs:
            f = f + np.asarray(du, dtype=float).reshape(q.shape[:-1] + (-1,)) @ self.B_du.T
        f = f - self.forces(q, v, np.asarray(gamma, dtype=float).tolist()) @ self.B_c
        return f / self.m

    def measure(self, q: np.ndarray, v: np.ndarray, a: Optional[np.ndarray] = None,
                ends: Optional[Tuple[np.ndarray, np.ndarray]] = None) -> np.ndarray:
        """Noise-free sensor readings (..., ns) from states (q, v) and, with an acceleration sensor, the
        bodies' accelerations a (docs/sensors.md); ends: the links' ground ends (base_ends), which a load cell
        in a link a base input moves reads (None: at rest)."""
        x = np.concatenate([np.asarray(q, dtype=float), np.asarray(v, dtype=float)], axis=-1)
        y = x @ self.H.T
        for i, (k, link) in enumerate(zip(self.sensor_kind.tolist(), self.sensor_link.tolist())):
            if k == ACCELERATION:
                if a is None:
                    raise ValueError(f"sensor{i + 1} reads an acceleration: measure needs the accelerations")
                y[..., i] = along(self.accel_dirs[i], _columns(np.asarray(a, dtype=float)))
            elif k == LINK_FORCE and ends is not None and self.has_base_inputs:
                # the ground end at u, moving at du/dt: +(k u + c du/dt) at end a, minus that at end b
                sign = 1.0 if int(self.spring_a[link]) < 0 else -1.0
                k, c = self.spring_k[link], self.spring_c[link]
                y[..., i] += sign * (k * ends[0][..., link] + c * ends[1][..., link])
        return y

    @property
    def has_acceleration(self) -> bool:
        return bool(np.any(self.sensor_kind == ACCELERATION))

    # ---- inputs -------------------------------------------------------------------------
    def inputs(self, t: "np.ndarray | float") -> np.ndarray:
        """Sine inputs u_i(t) = amp_i sin(2 pi freq_i t + phase_i), shape (..., ni)."""
        t = np.asarray(t, dtype=float)
        cols = [a * np.sin(2.0 * np.pi * f * t + p) for a, f, p in
                zip(self.input_amp.tolist(), self.input_freq.tolist(), self.input_phase.tolist())]
        return np.stack(cols, axis=-1) if cols else np.zeros(t.shape + (0,))

    def input_rates(self, t: "np.ndarray | float") -> np.ndarray:
        """The sines' rates du_i/dt = amp_i w_i cos(w_i t + phase_i), w_i = 2 pi freq_i, shape (..., ni)."""
        t = np.asarray(t, dtype=float)
        cols = [a * (2.0 * np.pi * f) * np.cos(2.0 * np.pi * f * t + p) for a, f, p in
                zip(self.input_amp.tolist(), self.input_freq.tolist(), self.input_phase.tolist())]
        return np.stack(cols, axis=-1) if cols else np.zeros(t.shape + (0,))

    def force(self, t: "np.ndarray | float") -> "np.ndarray | float":
        """Input 1's sine (the paper's single input u)."""
        return self.inputs(t)[..., 0]

    # ---- names --------------------------------------------------------------------------
    def sensor_names(self) -> Tuple[str, ...]:
        """y<body> (position), yv<body> (velocity), ya<body> (acceleration), yr<body>_<ref> (relative),
        yf<link> (link force): the paper's y1, y4."""
        if self.structure is not None:  # rows, not bodies: by sensor number (measurements.columns_of)
            return tuple(f"y{i}" for i in range(1, self.n_sensors + 1))
        out = []
        for b, k, r, link in zip(self.sensor_body.tolist(), self.sensor_kind.tolist(), self.sensor_ref.tolist(),
                                 self.sensor_link.tolist()):
            tail = f"{b + 1}_{r + 1}" if k == RELATIVE else str(link + 1) if k == LINK_FORCE else str(b + 1)
            out.append(SENSOR_PREFIX[k] + tail)
        return tuple(out)

    def input_names(self) -> Tuple[str, ...]:
        return ("u",) if self.n_inputs == 1 else tuple(f"u{i}" for i in range(1, self.n_inputs + 1))

    def delta_names(self) -> Tuple[str, ...]:
        return ("delta",) if self.n_contacts == 1 else tuple(f"delta{i}" for i in range(1, self.n_contacts + 1))


class _columns:
    """x[..., i] by x[i]: `along` over the last axis of a stack of states."""

    def __init__(self, x: np.ndarray) -> None:
        self.x = x

    def __getitem__(self, i: int) -> np.ndarray:
        return self.x[..., i]


def contact_values(sc: Any, key: str, nc: int) -> np.ndarray:
    """Per-contact values of `contact{i}_<key>` (gamma, gamma0, sigma_gamma0, ...), i = 1..nc."""
    return np.array([float(scenario_value(sc, f"contact{i}_{key}")) for i in range(1, nc + 1)])


def body_values(sc: Any, prefix: str, nq: int) -> np.ndarray:
    """Per-body values `<prefix><i>` (q0_, v0_), i = 1..nq."""
    return np.array([float(scenario_value(sc, f"{prefix}{i}")) for i in range(1, nq + 1)])


def read_input_csv(path: Any, n_inputs: int) -> Tuple[np.ndarray, np.ndarray]:
    """(t (M,), u (M, ni)) from a CSV with a header line and columns t,u1[,u2] (extra columns ignored)."""
    with open(path, encoding="utf-8") as f:
        header = [c.strip() for c in f.readline().split(",")]
    want = ["t"] + (["u1"] if n_inputs == 1 and "u1" in header else
                    ["u"] if n_inputs == 1 else [f"u{i}" for i in range(1, n_inputs + 1)])
    missing = [c for c in want if c not in header]
    if missing:
        raise ValueError(f"{path}: missing column '{missing[0]}' (need t,u1[,u2] for {n_inputs} inputs)")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    t = data[:, header.index("t")]
    if len(t) < 2 or not np.all(np.isfinite(data)) or np.any(np.diff(t) <= 0):
        raise ValueError(f"{path}: t must be finite and strictly increasing over >= 2 rows, u finite")
    return t, np.column_stack([data[:, header.index(c)] for c in want[1:]])


class InputSeries:
    """Inputs from samples (t_j, u_j): linear interpolation, end values held outside [t_0, t_last]."""

    def __init__(self, t: np.ndarray, u: np.ndarray) -> None:
        self.t = np.asarray(t, dtype=float)
        self.u = np.asarray(u, dtype=float).reshape(len(self.t), -1)

    def __call__(self, t: "np.ndarray | float") -> np.ndarray:
        t = np.asarray(t, dtype=float)
        cols = [np.interp(t, self.t, self.u[:, i]) for i in range(self.u.shape[1])]
        return np.stack(cols, axis=-1)

    def rate(self, t: "np.ndarray | float") -> np.ndarray:
        """du/dt (a base displacement's rate): the samples' central differences (u_{j+1} - u_{j-1}) / (t_{j+1} -
        t_{j-1}), one-sided at the ends, interpolated linearly; 0 outside [t_0, t_last], where u is held (the C
        truth's caekf_input_series_rate_at)."""
        t = np.asarray(t, dtype=float)
        ts, u = self.t, self.u
        nodes = np.empty_like(u)
        nodes[1:-1] = (u[2:] - u[:-2]) / (ts[2:] - ts[:-2])[:, None]
        nodes[0] = (u[1] - u[0]) / (ts[1] - ts[0])
        nodes[-1] = (u[-1] - u[-2]) / (ts[-1] - ts[-2])
        cols = [np.interp(t, ts, nodes[:, i], left=0.0, right=0.0) for i in range(u.shape[1])]
        return np.stack(cols, axis=-1)

