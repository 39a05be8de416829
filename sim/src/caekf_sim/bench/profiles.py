"""Protocol profiles: which messages of caekf.dbc carry one step, in and out.

The DBC holds every frame of every profile (one definition each); a profile only names them. The
estimator's profile is a runtime choice (`caekf-host --profile`), the bench's too
(`caekf-sim hil run --profile`); both sides must agree.

- diagnostics: BENCH_U, BENCH_Y1, BENCH_Y4 in; EST_GAMMA, EST_Q1..4, EST_V1..4, EST_P_NORM, EST_P_GG,
  EST_STEP out, every step (vcan; the HIL's reference for the equality with caekf-replay). Any mechanism
  within the DBC's sizes: `diagnostics_for` / `mechanism_profile` (its inputs and sensors in, every body's
  q and v and every contact's gamma and P_gamma,gamma out).
- production: BENCH_U, BENCH_YP in; EST_PROD out every step (gamma, the estimator's flags, STEP mod
  2^8); the rest of the estimate as EST_PAGE pages 0..10, one page per step at the first 11 steps of
  every page period (default 20 steps), for a real 1 Mbit/s classic bus.
- fd: BENCH_FD in, EST_FD out (CAN FD, 20 and 64 bytes, CRC-16 E2E), every value every step.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional, Tuple

from .codec import signal_length

# EST_PAGE page -> the results column it carries (page 10: flags, newton_iters, step_status)
PAGE_COLUMNS: Tuple[Tuple[int, str, str], ...] = (
    (0, "q1", "Q1"), (1, "q2", "Q2"), (2, "q3", "Q3"), (3, "q4", "Q4"),
    (4, "v1", "V1"), (5, "v2", "V2"), (6, "v3", "V3"), (7, "v4", "V4"),
    (8, "p_norm", "P_NORM"), (9, "p_gg", "P_GAMMA_GAMMA"),
    (10, "newton_iters", "NEWTON_ITERS"), (10, "step_status", "STEP_STATUS"),
)  # page 10 also carries the app's FLAGS bits; the estimator's bits 0..11 come with every EST_PROD
PAGE_COUNT = 11
DEFAULT_PAGE_PERIOD = 20
HEALTH_PAGES_PER_SECOND = 12.0  # EST_HEALTH burst at the default 1 s status period


@dataclass(frozen=True)
class Signal:
    """Where a results column comes from: message, signal, multiplexer page (None: not multiplexed)."""

    message: str
    signal: str
    page: Optional[int] = None


@dataclass(frozen=True)
class Profile:
    name: str
    inputs: Tuple[Tuple[str, Tuple[Tuple[str, str], ...]], ...]  # (message, ((signal, "u"|"y1"|"y4"), ...))
    closing: str  # the message that closes a step (the bench waits for it)
    closing_step_bits: int  # width of its STEP signal (at bit 12): the DBC's (codec.signal_length)
    results: Dict[str, Signal]  # results column -> where it is carried
    per_step: Dict[str, float]  # message -> frames per step (for the bus load), at the defaults

    @property
    def input_messages(self) -> Tuple[str, ...]:
        return tuple(m for m, _ in self.inputs)

    @property
    def flags_mask(self) -> int:
        """The flag bits the profile's every-step flags column carries: its signal's width (production's
        EST_PROD.FLAGS leaves MODEL_MISMATCH to EST_PAGE)."""
        s = self.results["flags"]
        return (1 << signal_length(s.message, s.signal)) - 1

    @property
    def step_mask(self) -> int:
        return (1 << self.closing_step_bits) - 1

    @property
    def every_step(self) -> Tuple[str, ...]:
        """Columns carried by every step (the others only at some steps)."""
        return tuple(c for c, s in self.results.items() if s.page is None)


_DIAG_RESULTS = {
    "q1": Signal("EST_Q1", "Q1"), "q2": Signal("EST_Q2", "Q2"), "q3": Signal("EST_Q3", "Q3"),
    "q4": Signal("EST_Q4", "Q4"), "v1": Signal("EST_V1", "V1"), "v2": Signal("EST_V2", "V2"),
    "v3": Signal("EST_V3", "V3"), "v4": Signal("EST_V4", "V4"), "gamma": Signal("EST_GAMMA", "GAMMA"),
    "p_norm": Signal("EST_P_NORM", "P_NORM"), "p_gg": Signal("EST_P_GG", "P_GAMMA_GAMMA"),
    "flags": Signal("EST_STEP", "FLAGS"), "newton_iters": Signal("EST_STEP", "NEWTON_ITERS"),
    "step_status": Signal("EST_STEP", "STEP_STATUS"),
}
_DIAG_OUT = ("EST_GAMMA", "EST_Q1", "EST_Q2", "EST_Q3", "EST_Q4", "EST_V1", "EST_V2", "EST_V3", "EST_V4",
             "EST_P_NORM", "EST_P_GG", "EST_STEP")

DIAGNOSTICS = Profile(
    name="diagnostics",
    inputs=(("BENCH_U", (("U", "u"),)), ("BENCH_Y1", (("Y1", "y1"),)), ("BENCH_Y4", (("Y4", "y4"),))),
    closing="EST_STEP",
    closing_step_bits=signal_length("EST_STEP", "STEP"),
    results=_DIAG_RESULTS,
    per_step={**{m: 1.0 for m in ("BENCH_U", "BENCH_Y1", "BENCH_Y4") + _DIAG_OUT},
              "EST_HEALTH": HEALTH_PAGES_PER_SECOND / 1000.0},
)


def production(page_period: int = DEFAULT_PAGE_PERIOD, rate_hz: float = 1000.0) -> Profile:
    results = {"gamma": Signal("EST_PROD", "GAMMA"), "flags": Signal("EST_PROD", "FLAGS")}
    for page, col, sig in PAGE_COLUMNS:
        results[col] = Signal("EST_PAGE", sig, page)
    return Profile(
        name="production",
        inputs=(("BENCH_U", (("U", "u"),)), ("BENCH_YP", (("Y1", "y1"), ("Y4", "y4")))),
        closing="EST_PROD",
        closing_step_bits=signal_length("EST_PROD", "STEP"),
        results=results,
        per_step={"BENCH_U": 1.0, "BENCH_YP": 1.0, "EST_PROD": 1.0,
                  "EST_PAGE": (PAGE_COUNT / page_period) if page_period else 0.0,
                  "EST_HEALTH": HEALTH_PAGES_PER_SECOND / rate_hz},
    )


PRODUCTION = production()

# CAN FD (1 Mbit/s arbitration, 5 Mbit/s data): BENCH_FD in, EST_FD out, every value every step at the
# diagnostics profile's resolution (the bench moves CAN FD records: Bench.open(profile="fd"))
FD = Profile(
    name="fd",
    inputs=(("BENCH_FD", (("U", "u"), ("Y1", "y1"), ("Y4", "y4"))),),
    closing="EST_FD",
    closing_step_bits=signal_length("EST_FD", "STEP"),
    results={col: Signal("EST_FD", src.signal) for col, src in _DIAG_RESULTS.items()},
    per_step={"BENCH_FD": 1.0, "EST_FD": 1.0, "EST_HEALTH": HEALTH_PAGES_PER_SECOND / 1000.0},
)
DATA_BITRATE = 5e6  # CAN FD data phase of the fd profile's bus load

PROFILES: Dict[str, Profile] = {p.name: p for p in (DIAGNOSTICS, PRODUCTION, FD)}

# A mechanism's step values in the diagnostics profile (firmware/app/src/app_assembly.c): input i and sensor s
# by their index; StepInputs keys them as below (the paper's names for input 1 and sensors 1, 2).
INPUT_KEYS = ("u", "u2")
SENSOR_KEYS = ("y1", "y4", "y3s", "y4s")
INPUT_FRAMES = (("BENCH_U", "U"), ("BENCH_U2", "U2"))
POSITION_FRAMES = (("BENCH_Y1", "Y1"), ("BENCH_Y4", "Y4"), ("BENCH_S3_POS", "S3_POS"), ("BENCH_S4_POS", "S4_POS"))
VELOCITY_FRAMES = tuple((f"BENCH_S{s}_VEL", f"S{s}_VEL") for s in range(1, 5))
MAX_DIAG_BODIES = 8
MAX_DIAG_CONTACTS = 2


def diagnostics_for(n_inputs: int, sensor_kinds, n_bodies: int, n_contacts: int) -> Profile:
    """The diagnostics profile of a mechanism (sizes within the DBC's: 2 inputs, 4 sensors, 8 bodies, 2
    contacts): input i on BENCH_U / BENCH_U2, sensor s on its kind's frame (position: BENCH_Y1, BENCH_Y4,
    BENCH_S3_POS, BENCH_S4_POS; velocity: BENCH_S<s>_VEL), and back EST_Q/EST_V of every body, EST_GAMMA,
    EST_P_NORM, EST_P_GG, EST_GAMMA2 and EST_P_GG2 with two contacts, EST_STEP. The paper's mechanism (1 input,
    2 position sensors, 4 bodies, 1 contact) gives DIAGNOSTICS itself."""
    kinds = [int(k) for k in sensor_kinds]
    if not (0 <= n_inputs <= len(INPUT_FRAMES) and len(kinds) <= len(SENSOR_KEYS)
            and 1 <= n_bodies <= MAX_DIAG_BODIES and 0 <= n_contacts <= MAX_DIAG_CONTACTS):
        raise ValueError(f"a mechanism of {n_bodies} bodies, {n_inputs} inputs, {len(kinds)} sensors, {n_contacts} "
                         f"contacts is beyond the diagnostics frames ({MAX_DIAG_BODIES} bodies, {len(INPUT_FRAMES)} "
                         f"inputs, {len(SENSOR_KEYS)} sensors, {MAX_DIAG_CONTACTS} contacts)")
    inputs = [(m, ((sig, INPUT_KEYS[i]),)) for i, (m, sig) in enumerate(INPUT_FRAMES[:n_inputs])]
    for s, kind in enumerate(kinds):
        m, sig = (VELOCITY_FRAMES if kind else POSITION_FRAMES)[s]
        inputs.append((m, ((sig, SENSOR_KEYS[s]),)))
    results = {"gamma": Signal("EST_GAMMA", "GAMMA")}
    for i in range(1, n_bodies + 1):
        results[f"q{i}"] = Signal(f"EST_Q{i}", f"Q{i}")
    for i in range(1, n_bodies + 1):
        results[f"v{i}"] = Signal(f"EST_V{i}", f"V{i}")
    results["p_norm"] = Signal("EST_P_NORM", "P_NORM")
    results["p_gg"] = Signal("EST_P_GG", "P_GAMMA_GAMMA")
    if n_contacts > 1:
        results["gamma2"] = Signal("EST_GAMMA2", "GAMMA2")
        results["p_gg2"] = Signal("EST_P_GG2", "P_GAMMA2_GAMMA2")
    for col in ("flags", "newton_iters", "step_status"):
        results[col] = _DIAG_RESULTS[col]
    out = tuple(dict.fromkeys(s.message for s in results.values()))
    out = tuple(m for m in out if m != "EST_STEP") + ("EST_STEP",)
    prof = Profile(
        name="diagnostics",
        inputs=tuple(inputs),
        closing="EST_STEP",
        closing_step_bits=signal_length("EST_STEP", "STEP"),
        results=results,
        per_step={**{m: 1.0 for m, _ in inputs}, **{m: 1.0 for m in out},
                  "EST_HEALTH": HEALTH_PAGES_PER_SECOND / 1000.0},
    )
    return DIAGNOSTICS if (prof.inputs == DIAGNOSTICS.inputs and prof.results == DIAGNOSTICS.results) else prof


def mechanism_profile(mech) -> Profile:
    """diagnostics_for a caekf_sim.mechanism.Mechanism."""
    return diagnostics_for(mech.n_inputs, mech.sensor_kind.tolist(), mech.nq, mech.n_contacts)


def get_profile(name: str) -> Profile:
    try:
        return PROFILES[name]
    except KeyError:
        raise ValueError(f"unknown profile {name!r} (known: {', '.join(PROFILES)})") from None
