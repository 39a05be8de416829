"""Structural draws of a family spec ([structure], docs/family.md): a chain of drawn length with its
contacts, ground links, inputs and sensors, and the forcing amplitude that closes every contact.

The chain: bodies 1..n on a line; each pair of neighbours (i, i+1) is joined by a spring-damper link or,
where a contact is placed, by the contact alone (the paper's bodies 2 and 3), so contacts split the chain
into spring-connected pieces; each piece is linked to the ground at one of its ends (drawn), every other
body with probability `extra_ground_link`. A contact goes to the ground (a stop that body meets after
moving `gap` either way) with probability `ground_contact`, else between drawn neighbours. Inputs and
sensors sit on drawn distinct bodies. Two contacts close on opposite half-waves of the forcing (as the
shuttle example's end stops), so that each closes while the other is open. The counts (bodies,
contacts, inputs, sensors) are drawn once; the placement is kept only if every contact can close
quasi-statically (its penetration moves with the inputs; opposite half-waves for two) and is observed
(a sensor on a piece it touches), else placed again from the same generator (deterministic), so the
counts follow their distributions.

Key names come from the settings schema (its key patterns); this module knows the settings of the
mechanism's structure by name, nothing else.
"""
from __future__ import annotations

import math
from typing import Any, Dict, List, Mapping, Optional, Tuple

import numpy as np

from ..schema import SCHEMA

MAX_ATTEMPTS = 1000  # structures drawn at most per run before giving up (a spec that cannot be met)
PROBABILITIES = ("ground_contact", "extra_ground_link", "velocity_sensor")
COUNTS = ("bodies", "contacts", "inputs", "sensors")
KEYS = COUNTS + PROBABILITIES + ("closing",)
SENSOR_KINDS = SCHEMA.by_name("sensor_kind").values  # ("position", "velocity")


def key(setting: str, i: int) -> str:
    """Scenario key of element i (1-based) of a schema setting: key("spring_k", 2) = "spring2_k"."""
    return SCHEMA.by_name(setting).keys[i - 1]


def count_key(capacity: str) -> str:
    """Scenario key of the setting that counts a capacity's elements in use ("contacts")."""
    for s in SCHEMA.settings:
        if s.counts == capacity:
            return s.keys[0]
    raise KeyError(capacity)


def _pieces(n: int, split_after: List[int]) -> List[List[int]]:
    """Spring-connected pieces of the chain 1..n cut after each body in split_after."""
    out, cur = [], []
    for b in range(1, n + 1):
        cur.append(b)
        if b in split_after or b == n:
            out.append(cur)
            cur = []
    return out


def draw_structure(rng: np.random.Generator, spec: Mapping[str, Any], draw_value: Any,
                   where: str) -> Dict[str, float]:
    """Scenario values of one drawn structure (counts, link and contact ends, input and sensor bodies and
    kinds) plus the auxiliary `closing`. `draw_value(rng, name, dist)` draws one value of a distribution."""
    unknown = sorted(set(spec) - set(KEYS))
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {', '.join(unknown)} in [structure] ({', '.join(KEYS)})")
    for k in ("bodies", "contacts"):
        if k not in spec:
            raise ValueError(f"{where}: [structure] needs {k}")
    cap = SCHEMA.capacity
    prob = {}
    for k in PROBABILITIES:
        p = float(spec.get(k, 0.0))
        if not 0.0 <= p <= 1.0:
            raise ValueError(f"{where}: [structure] {k} = {p:g}: a probability in [0, 1]")
        prob[k] = p

    def count(name: str, default: int, lo: int) -> int:
        d = spec.get(name, {"dist": "fixed", "value": default})
        v = draw_value(rng, name, d) if isinstance(d, Mapping) else float(d)
        hi = cap[name]
        if v != int(v) or not lo <= v <= hi:
            raise ValueError(f"{where}: [structure] {name} = {v:g}: must be an integer in {lo}..{hi}")
        return int(v)

    n = count("bodies", 4, 1)
    nc = count("contacts", 1, 1)
    ni = min(count("inputs", 1, 1), n)
    ns = min(count("sensors", 2, 1), n)
    for _ in range(MAX_ATTEMPTS):
        out = _try_structure(rng, n, nc, ni, ns, prob)
        if out is not None:
            break
    else:
        raise ValueError(f"{where}: no structure of {n} bodies, {nc} contacts, {ni} inputs, {ns} sensors in "
                         f"{MAX_ATTEMPTS} draws has every contact closing and observed")
    closing = spec.get("closing")
    if closing is not None:
        out["closing"] = draw_value(rng, "closing", closing) if isinstance(closing, Mapping) else float(closing)
    return out


def _try_structure(rng: np.random.Generator, n: int, nc: int, ni: int, ns: int,
                   prob: Mapping[str, float]) -> Optional[Dict[str, float]]:
    """One attempt; None when a contact could not close or is not observed, or the links exceed capacity."""
    contacts: List[Tuple[int, int]] = []  # (a, b), 0 = ground
    free_gaps = list(range(1, n))  # neighbour pairs (i, i+1) still joined by a spring
    for _ in range(nc):
        to_ground = rng.random() < prob["ground_contact"] or not free_gaps
        if to_ground:
            body = int(rng.integers(1, n + 1))
            c = (body, 0) if rng.random() < 0.5 else (0, body)
            if c in contacts:
                return None
        else:
            i = free_gaps.pop(int(rng.integers(len(free_gaps))))
            c = (i, i + 1)
        contacts.append(c)
    split = [a for a, b in contacts if a and b]
    pieces = _pieces(n, split)
    springs: List[Tuple[int, int]] = [(i, i + 1) for i in range(1, n) if i not in split]
    grounded = set()
    for p in pieces:
        end = p[0] if rng.random() < 0.5 else p[-1]
        grounded.add(end)
    for b in range(1, n + 1):
        if b not in grounded and rng.random() < prob["extra_ground_link"]:
            grounded.add(b)
    springs += [(b, 0) for b in sorted(grounded)]
    if len(springs) > SCHEMA.capacity["springs"]:
        return None
    inputs = sorted(int(b) for b in rng.choice(np.arange(1, n + 1), size=ni, replace=False))
    sensors = sorted(int(b) for b in rng.choice(np.arange(1, n + 1), size=ns, replace=False))
    kinds = [1 if rng.random() < prob["velocity_sensor"] else 0 for _ in sensors]
    piece_of = {b: k for k, p in enumerate(pieces) for b in p}
    sensed = {piece_of[b] for b in sensors}
    if any(not {piece_of[x] for x in (a, b) if x} & sensed for a, b in contacts):
        return None  # a contact no sensor sees
    # quasi-static closing with unit springs (the signs of K^-1 do not depend on the stiffnesses)
    if not _closes_alone(_static_shift(n, springs, [1.0] * len(springs), inputs, contacts)):
        return None
    out: Dict[str, float] = {count_key("bodies"): n, count_key("springs"): len(springs),
                             count_key("contacts"): nc, count_key("inputs"): ni, count_key("sensors"): ns}
    for i, (a, b) in enumerate(springs, start=1):
        out[key("spring_a", i)], out[key("spring_b", i)] = a, b
    for i, (a, b) in enumerate(contacts, start=1):
        out[key("contact_a", i)], out[key("contact_b", i)] = a, b
    for i, b in enumerate(inputs, start=1):
        out[key("input_body", i)] = b
    for i, (b, k) in enumerate(zip(sensors, kinds), start=1):
        out[key("sensor_body", i)], out[key("sensor_kind", i)] = b, k
    return {k: float(v) for k, v in out.items()}


def _static_shift(n: int, springs: List[Tuple[int, int]], k: List[float], inputs: List[int],
                  contacts: List[Tuple[int, int]]) -> np.ndarray:
    """s_c = b_c^T K^-1 B_u 1 of every contact: how far its penetration moves per newton of the inputs."""
    K = np.zeros((n + 1, n + 1))  # row/column 0: the ground, dropped below
    for (a, b), kk in zip(springs, k):
        K[a, a] += kk
        K[b, b] += kk
        K[a, b] -= kk
        K[b, a] -= kk
    f = np.zeros(n + 1)
    f[inputs] = 1.0
    q = np.zeros(n + 1)
    q[1:] = np.linalg.solve(K[1:, 1:], f[1:])
    return np.array([q[a] - q[b] for a, b in contacts])


def _closes_alone(s: np.ndarray) -> bool:
    """Every contact moves with the inputs (s_c != 0), and two contacts close on opposite half-waves of the
    sine (s of opposite signs), so each closes while the other is open and the static rule holds for both."""
    if not np.any(s) or np.any(np.abs(s) <= 1e-12 * np.max(np.abs(s))):
        return False
    return len(set(np.sign(s).tolist())) == len(s)


def closing_amplitude(values: Mapping[str, Any]) -> Tuple[float, np.ndarray]:
    """The input amplitude that just closes every contact quasi-statically, and each contact's.

    Static equilibrium of the drawn mechanism under every input at amplitude a, in phase: K q = B_u 1 a.
    Contact c's penetration moves by s_c a with s_c = b_c^T K^-1 B_u 1, so it closes (on one half of the
    sine or the other) once |s_c| a >= gap_c: a_c = gap_c / |s_c|. The amplitude closing every contact
    is max_c a_c (generalises the paper family's k1 * gap). Two contacts must close on opposite half-waves
    (s_1 s_2 < 0: each closes while the other is open, so the linear rule holds for both); otherwise, or
    when a contact does not move with the inputs, the amplitude is inf."""
    from ..mechanism import Mechanism

    mech = Mechanism.from_scenario(dict(values))
    q = np.linalg.solve(mech.K, mech.B_u @ np.ones(mech.n_inputs))
    s = mech.B_c @ q
    if not _closes_alone(s):
        return math.inf, np.full(len(s), math.inf)
    a_c = mech.contact_gap / np.abs(s)
    return float(np.max(a_c)), a_c


def forcing(values: Mapping[str, Any], closing: float) -> Dict[str, float]:
    """input{i}_amp of every input: `closing` times the amplitude that closes every contact."""
    a, _ = closing_amplitude(values)
    if not math.isfinite(a):
        raise ValueError("a contact cannot close quasi-statically under the inputs, or two close on the same "
                         "half-wave")
    ni = int(values[count_key("inputs")])
    return {key("input_amp", i): closing * a for i in range(1, ni + 1)}
