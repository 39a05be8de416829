"""The shipped C estimator (firmware/core) from Python, in double and in float.

    import caekf_sim
    est = caekf_sim.Estimator("sim/scenarios/paper.toml")          # recommended settings, double
    rep = est.step(u, [q1, q4])                                    # Report(flags, nis, newton_iters, delta, status)
    est.gamma, est.x, est.P                                        # SI units
    res = caekf_sim.run(scenario, u, y, experiment="canonical", precision="float")   # whole loop in C

The modules caekf_sim._caekf_double and caekf_sim._caekf_float are the same C sources compiled with
CAEKF_USE_FLOAT=0 and 1 (sim/CMakeLists.txt, built by `pip install ./sim`). Results equal caekf-replay's
bit for bit on the same inputs (sim/tests/test_binding.py). Units: u [N], y = [q1, q4] [m], x = [q1..q4 [m],
v1..v4 [m/s], gamma [N/m^1.5]], t [s]; P in the same units squared.

`run` is a plain module-level function of numpy arrays and picklable settings, so it runs as it is in
process pools and on Dask workers.
"""
from __future__ import annotations

import hashlib
import math
import importlib
import re
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, Dict, List, NamedTuple, Optional, Sequence, Union

import numpy as np

from .scenario import PathLike, Scenario, load_scenario
from .settings_adapter import Settings, check_precision, settings_for

if TYPE_CHECKING:
    from .truth import Truth

N = 9  # augmented state [q1..q4, v1..v4, gamma]
IG = 8  # index of gamma

ScenarioOrSettings = Union[Scenario, Settings, str, Path]


class SettingsError(ValueError):
    """Settings refused by caekf_settings_validate; the message is caekf-replay's:
    'settings refused: m[2] = -1: must be finite and > 0'."""


class BindingError(RuntimeError):
    """The C extension is missing or was built from other sources than the checkout's."""


class Report(NamedTuple):
    """What one caekf_step / caekf_predict did (caekf_report_t plus the call's status)."""

    flags: int  # CAEKF_FLAG_* bits (caekf_sim.flags)
    nis: float  # normalised innovation squared of the correction (0 without one); chi-square, 2 dof
    newton_iters: int  # Newton iterations of the prediction
    delta: float  # predicted penetration delta(x_k-) [m]
    status: int  # caekf_status_t: 0 ok, -4 input rejected, -5 numeric rollback, ...

    @property
    def flag_names(self) -> List[str]:
        from .flags import describe

        return describe(self.flags)


_MODULES: Dict[str, ModuleType] = {}


def _module(precision: str) -> ModuleType:
    """The C module of one precision, imported once."""
    mod = _MODULES.get(precision)
    if mod is None:
        name = f"caekf_sim._caekf_{check_precision(precision)}"
        try:
            mod = importlib.import_module(name)
        except ImportError as exc:
            raise BindingError(f"{name} is not built ({exc}); install the package with `pip install ./sim` "
                               "(or tools/bootstrap.sh)") from None
        mod._set_report_type(Report)
        _MODULES[precision] = mod
    return mod


def source_hash(repo: PathLike) -> str:
    """Hash of the C files the modules are built from, as sim/CMakeLists.txt computes it."""
    root = Path(repo)
    core = root / "firmware" / "core"
    listed = re.findall(r"\$\{CMAKE_CURRENT_LIST_DIR\}/(\S+\.c)", (core / "sources.cmake").read_text())
    files = [root / "sim/src/caekf_sim/schema" / f for f in ("settings.toml", "codegen.py")]
    files += [core / f for f in listed]
    files += [root / "host/common" / f for f in ("scenario.c", "scenario.h", "truth.c", "truth.h")]
    files += [root / "sim/src/caekf_sim/_caekf.c"]
    files += sorted(list((root / "firmware/include/caekf").glob("*.h")) + list(core.glob("*.h")),
                    key=lambda p: str(p))
    text = "".join(f"{p.relative_to(root).as_posix()}={hashlib.sha256(p.read_bytes()).hexdigest()}\n"
                   for p in files)
    return hashlib.sha256(text.encode()).hexdigest()


def check_build(repo: PathLike) -> None:
    """Raise BindingError when the installed modules were built from other C sources than `repo`'s
    (an editable install after a C change: rerun tools/bootstrap.sh, which rebuilds them)."""
    want = source_hash(repo)
    for p in ("double", "float"):
        have = _module(p).SOURCE_HASH
        if have != want:
            raise BindingError(f"caekf_sim._caekf_{p} was built from other C sources than {repo} "
                               "(rerun tools/bootstrap.sh or pip install ./sim)")


def _settings(what: ScenarioOrSettings, precision: Optional[str], experiment: Optional[str],
              overrides: Dict[str, Any]) -> Settings:
    if isinstance(what, Settings):
        if experiment is not None:
            raise ValueError("experiment applies to a scenario; these are settings already "
                             "(caekf_sim.settings_for(scenario, experiment) makes them)")
        if precision is not None and check_precision(precision) != what.precision:
            raise ValueError(f"these settings were built for {what.precision}, not {precision} "
                             f"(use caekf_sim.settings_for(..., precision={precision!r}))")
        return what.replace(**overrides) if overrides else what
    if isinstance(what, (str, Path)):
        path = Path(what)
        if not path.is_file():
            raise FileNotFoundError(f"scenario file not found: {path}")
        what = load_scenario(path)
    if isinstance(what, Scenario):
        return settings_for(what, experiment, precision or "double", **overrides)
    raise TypeError(f"expected a Scenario, Settings or scenario file path, got {type(what).__name__}")


@dataclass
class RunResult:
    """Per-step output of :func:`run`, one row per input sample (numpy arrays, picklable)."""

    t: np.ndarray  # (n,) [s]
    x: np.ndarray  # (n, 9) posterior [q [m], v [m/s], gamma [N/m^1.5]]
    P_diag: Optional[np.ndarray]  # (n, 9) diagonal of P (physical units squared)
    flags: np.ndarray  # (n,) uint32 CAEKF_FLAG_* bits
    nis: np.ndarray  # (n,) normalised innovation squared (0 on steps without correction)
    newton_iters: np.ndarray  # (n,) int32
    delta: np.ndarray  # (n,) predicted penetration [m]
    status: np.ndarray  # (n,) int8 caekf_status_t of each call
    has_y: np.ndarray  # (n,) bool: False where caekf_predict bridged a missing measurement
    p_norm: Optional[np.ndarray]  # (n,) 2-norm of P, when asked for (p_norm=True)
    log_det_s: Optional[np.ndarray]  # (n,) log det of the innovation covariance [log m^4], when asked for
    settings: Settings

    @property
    def precision(self) -> str:
        return self.settings.precision

    @property
    def gamma(self) -> np.ndarray:
        """Contact stiffness estimate [N/m^1.5]."""
        return self.x[:, IG]

    @property
    def p_gg(self) -> Optional[np.ndarray]:
        """Variance of gamma [(N/m^1.5)^2]."""
        return None if self.P_diag is None else self.P_diag[:, IG]

    @property
    def flags_seen(self) -> int:
        return int(np.bitwise_or.reduce(self.flags)) if len(self.flags) else 0

    def __len__(self) -> int:
        return len(self.t)


class Estimator:
    """The C estimator (caekf_t) of one precision.

    Estimator(scenario_or_settings, precision="double", experiment=None, **overrides)

    * `scenario_or_settings`: a Scenario, a scenario file path (sim/scenarios/paper.toml format) or
      Settings. A scenario is mapped to settings by caekf-replay's rule: the schema's defaults, the
      scenario's values, then the preset `experiment` if given (canonical, switched, switched-highq,
      switched-highq-constrained); `overrides` change single
      settings (e.g. gamma_gate_nis=0, sigma_r=1e-6).
    * `precision`: "double" or "float" (default double, or the precision Settings were built for).

    Settings are checked by caekf_settings_validate; a refusal raises SettingsError("settings refused: m[2] = -1: ..."),
    caekf-replay's message. step/predict are the C calls themselves (no Python frame in between).
    """

    def __init__(self, scenario_or_settings: ScenarioOrSettings, precision: Optional[str] = None,
                 experiment: Optional[str] = None, **overrides: Any) -> None:
        s = _settings(scenario_or_settings, precision, experiment, overrides)
        c = _module(s.precision)
        d = s.to_c()
        bad = c.settings_validate(d)
        if bad is not None:
            raise SettingsError(f"settings refused: {bad[1]}")
        self._c = c.Estimator(d)
        self.settings = s
        # The C methods straight on the instance: a call costs what the C function does plus argument parsing.
        self.step = self._c.step  # type: ignore[method-assign]
        self.predict = self._c.predict  # type: ignore[method-assign]

    # Documented signatures; __init__ binds the C methods over them.
    def step(self, u: float, y: Sequence[float]) -> Report:  # pragma: no cover - replaced per instance
        """caekf_step: input force u [N], measurement y = [q1, q4] [m]. Non-finite input is refused
        (status -4, flag INPUT_REJECTED, state untouched); never raises for it."""
        return self._c.step(u, y)

    def predict(self, u: float) -> Report:  # pragma: no cover - replaced per instance
        """caekf_predict: time update without measurement (a lost sample), input force u [N]."""
        return self._c.predict(u)

    @property
    def precision(self) -> str:
        return self.settings.precision

    @property
    def x(self) -> np.ndarray:
        """Augmented state [q1..q4 [m], v1..v4 [m/s], gamma [N/m^1.5]] (caekf_get_state)."""
        out = np.empty(N)
        self._c._state_into(out)
        return out

    @property
    def gamma(self) -> float:
        """Contact stiffness estimate [N/m^1.5] (caekf_get_gamma)."""
        return self._c.gamma

    @property
    def P(self) -> np.ndarray:
        """Covariance (9, 9) in physical units (caekf_get_covariance)."""
        out = np.empty((N, N))
        self._c._cov_into(out)
        return out

    @property
    def p_norm(self) -> float:
        """2-norm of P in physical units (caekf_get_cov_norm2)."""
        return self._c.p_norm()

    @property
    def step_count(self) -> int:
        return self._c.step_count

    @property
    def last_flags(self) -> int:
        return self._c.last_flags

    def reset(self) -> None:
        """Back to the initial estimate (caekf_init with the same settings)."""
        self._c.reset()

    def run(self, u: np.ndarray, y: np.ndarray, *, t: Optional[np.ndarray] = None,
            has_y: Optional[np.ndarray] = None, missing_y: str = "predict", p_diag: bool = True,
            p_norm: bool = False, log_det_s: bool = False) -> RunResult:
        """Continue over n samples in C from the current state; see :func:`run`."""
        u = np.ascontiguousarray(u, dtype=np.float64).reshape(-1)
        y = np.ascontiguousarray(y, dtype=np.float64)
        n = len(u)
        if y.shape != (n, 2):
            raise ValueError(f"y must have shape ({n}, 2) (q1, q4 per sample of u), got {y.shape}")
        if has_y is not None:
            has = np.ascontiguousarray(has_y, dtype=np.bool_).reshape(-1)
            if len(has) != n:
                raise ValueError(f"has_y must have {n} entries, got {len(has)}")
        elif missing_y == "predict":
            has = ~(np.isnan(y[:, 0]) & np.isnan(y[:, 1]))
        elif missing_y == "reject":
            has = np.ones(n, dtype=np.bool_)
        else:
            raise ValueError(f"missing_y must be 'predict' or 'reject', got {missing_y!r}")
        if t is None:
            t = self.settings.dt * np.arange(1, n + 1, dtype=np.float64)
        else:
            t = np.asarray(t, dtype=np.float64).reshape(-1)
            if len(t) != n:
                raise ValueError(f"t must have {n} entries, got {len(t)}")
        x = np.empty((n, N))
        pd = np.empty((n, N)) if p_diag else None
        flags = np.empty(n, dtype=np.uint32)
        iters = np.empty(n, dtype=np.int32)
        nis = np.empty(n)
        delta = np.empty(n)
        status = np.empty(n, dtype=np.int8)
        pn = np.empty(n) if p_norm else None
        ld = np.empty(n) if log_det_s else None
        self._c._run(u, y, None if has.all() else has, x, pd, flags, iters, nis, delta, status, pn, ld)
        return RunResult(t=t, x=x, P_diag=pd, flags=flags, nis=nis, newton_iters=iters, delta=delta,
                         status=status, has_y=has, p_norm=pn, log_det_s=ld, settings=self.settings)

    # pickling: settings plus the raw caekf_t (same build only)
    def __getstate__(self) -> Dict[str, Any]:
        return {"settings": self.settings, "raw": self._c._get_raw()}

    def __setstate__(self, state: Dict[str, Any]) -> None:
        self.__init__(state["settings"])  # type: ignore[misc]
        self._c._set_raw(state["raw"])

    def __repr__(self) -> str:
        return (f"Estimator({self.precision}, mode={self.settings.mode}, gamma={self.gamma:.6g}, "
                f"steps={self.step_count})")


def run(scenario_or_settings: ScenarioOrSettings, u: np.ndarray, y: np.ndarray, *,
        t: Optional[np.ndarray] = None, precision: Optional[str] = None, experiment: Optional[str] = None,
        has_y: Optional[np.ndarray] = None, missing_y: str = "predict", p_diag: bool = True,
        p_norm: bool = False, log_det_s: bool = False, **overrides: Any) -> RunResult:
    """Run the C estimator over a whole record, the loop in C (no GIL held), from its initial estimate.

    u: (n,) input force [N]; y: (n, 2) measurements [q1, q4] [m]; t: (n,) sample times [s] (default
    k dt, k = 1..n). A row whose y1 and y4 are both NaN is a lost measurement bridged by caekf_predict, as
    `caekf-replay --missing-y-predict` does (missing_y="predict"); missing_y="reject" hands such rows to
    caekf_step, which refuses them (flag INPUT_REJECTED) like `--allow-nonfinite`. `has_y` (n,) bool sets
    the rows explicitly. `p_norm` adds the 2-norm of P per step (costly Jacobi sweeps, as caekf-replay's
    p_norm column); `log_det_s` the log-determinant of each correction's innovation covariance (for the
    innovation likelihood; NaN on steps without a plain correction). Settings as for :class:`Estimator`.

    A pure function of its arguments (numpy arrays, Scenario or Settings): picklable, so it runs as it is
    in process pools and on Dask workers.
    """
    est = Estimator(scenario_or_settings, precision, experiment, **overrides)
    return est.run(u, y, t=t, has_y=has_y, missing_y=missing_y, p_diag=p_diag, p_norm=p_norm,
                   log_det_s=log_det_s)


def status_str(status: int, precision: str = "double") -> str:
    """caekf_status_str: the text of a caekf_status_t (Report.status, RunResult.status)."""
    return _module(precision).status_str(int(status))


def flag_name(bit: int, precision: str = "double") -> str:
    """caekf_flag_name: the name of flag bit `bit` (0..CAEKF_FLAG_COUNT-1)."""
    return _module(precision).flag_name(int(bit))


def experiment_names(precision: str = "double") -> tuple:
    """The presets of the settings schema, as the C tools know them (the paper's four experiments)."""
    return _module(precision).preset_names()


def truth(sc: Scenario) -> "Truth":
    """The truth of scenario `sc` from caekf-truth's C generator (host/common/truth.c, double): the same
    samples as `caekf-truth` writes, bit for bit, far faster than caekf_sim.truth.simulate (whose noise
    generator differs: numpy's, not splitmix64). Returns caekf_sim.truth.Truth (t [s], u [N], y [m],
    q [m], v [m/s], delta [m]); a pure function, picklable for process pools and Dask."""
    from .settings_adapter import scenario_dict
    from .truth import Truth

    x = sc.t_end / sc.dt
    n = int(math.floor(x + 0.5)) if x > 0 else 0  # caekf_scenario_steps: lround
    t, u, delta = np.empty(n), np.empty(n), np.empty(n)
    y, q, v = np.empty((n, 2)), np.empty((n, 4)), np.empty((n, 4))
    iters, failed = np.empty(n, dtype=np.int32), np.empty(n, dtype=np.int32)
    _module("double").truth(scenario_dict(sc), t, u, y, q, v, delta, iters, failed)
    return Truth(t=t, u=u, y=y, q=q, v=v, delta=delta)
