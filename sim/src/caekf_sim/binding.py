"""The shipped C estimator (firmware/core) from Python, in double and in float.

    import caekf_sim
    est = caekf_sim.Estimator("sim/scenarios/paper.toml")          # recommended settings, double
    rep = est.step(u, [q1, q4])                                    # Report(flags, nis, newton_iters, delta, status)
    est.gamma, est.x, est.P                                        # SI units
    res = caekf_sim.run(scenario, u, y, experiment="canonical", precision="float")   # whole loop in C

Any mechanism the scenario describes (docs/scenario.md): bodies, links, inputs, sensors and contacts. Its
sizes come from the estimator (caekf_get_sizes): `n` = 2 bodies + contacts states x = [q_1..q_nq [m],
v_1..v_nq [m/s], gamma_1..gamma_nc [N/m^n_c]], `sensors` measurements y per step (position [m] or
velocity [m/s], in the order of the scenario's sensors) and `inputs` forces u per step [N] (a number where
there is one input). `gamma` is contact 1's stiffness, `gammas` every contact's. On the paper's mechanism:
u [N] a number, y = [q1, q4] [m], x = [q1..q4, v1..v4, gamma] (n = 9).

The modules caekf_sim._caekf_double and caekf_sim._caekf_float are the same C sources compiled with
CAEKF_USE_FLOAT=0 and 1 (sim/CMakeLists.txt, built by `pip install ./sim`) for the host's capacity
(MAX_BODIES, MAX_SENSORS, MAX_INPUTS, MAX_CONTACTS of the module). Results equal caekf-replay's bit for bit
on the same inputs (sim/tests/test_binding.py); t [s]; P in the units of x squared.

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
from typing import TYPE_CHECKING, Any, Dict, List, NamedTuple, Optional, Sequence, Tuple, Union

import numpy as np

from . import schema
from .scenario import PathLike, Scenario, load_scenario, require_truth
from .settings_adapter import Settings, check_precision, scenario_dict

if TYPE_CHECKING:
    from .truth import Truth

# The paper's mechanism (4 bodies, 1 contact): its state size and the index of its gamma. A general
# mechanism's are Estimator.n and Estimator.gamma_index (RunResult.n, RunResult.gamma_index).
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
    nis: float  # normalised innovation squared of the correction (0 without one); chi-square, `sensors` dof
    newton_iters: int  # Newton iterations of the prediction
    delta: float  # deepest predicted penetration over the contacts, max_c delta_c(x_k-) [m]
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


def settings_for(sc: Scenario, experiment: Optional[str] = None, precision: str = "double",
                 **overrides: Any) -> Settings:
    """Settings of scenario `sc` with a preset (the paper's canonical, switched, switched-highq,
    switched-highq-constrained; None: the schema's defaults, the recommended estimator), as caekf-replay
    builds them: the C function caekf_scenario_settings of the `precision` build, through the binding.
    `overrides` then change single settings (e.g. gamma_gate_nis=0)."""
    c = _module(check_precision(precision))
    # The keys a file would give: a default relative to the build's epsilon stays the build's own.
    given = dict(schema.wire_values(sc.values()))
    given.update({k: v for k, v in sc.values().items() if k not in schema.param_ids()})
    s = Settings(tuple(c.scenario_settings(given, experiment)), precision)
    return s.replace(**overrides) if overrides else s


def default_settings(precision: str = "double", **values: Any) -> Settings:
    """caekf_settings_default of the `precision` build (zero model: fill it through `values`)."""
    s = Settings(tuple(_module(check_precision(precision)).settings_default()), precision)
    return s.replace(**values) if values else s


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


def paper_mismatch(sc: Scenario) -> Optional[str]:
    """None when scenario `sc` describes the paper's mechanism (4 bodies chained as in docs/scenario.md,
    the input on body 1, position sensors on bodies 1 and 4, one Hertzian contact 2-3), else its first
    difference, e.g. "bodies = 3 (the paper's chain has 4)"."""

    return _module("double").paper_mismatch(scenario_dict(sc))


def require_paper_mechanism(sc: Scenario, what: str) -> None:
    """Raise a one-line ValueError when `what` (code that handles the paper's mechanism only) gets another."""
    diff = paper_mismatch(sc)
    if diff is not None:
        raise ValueError(f"{what} handles the paper's mechanism only: {diff}")


def _gamma_index(settings: Settings) -> int:
    """Index of contact 1's gamma in x: 2 bodies."""
    return 2 * int(settings.bodies)


def _law_columns(settings: Settings, x: np.ndarray, dofs: int = -1) -> Dict[str, np.ndarray]:
    """The law states of x (last axis) by column name: they follow the 2 bodies (a structure's 2 dofs) +
    contacts states."""
    from .mechanism import law_column_names, law_layout

    nc = int(settings.contacts)
    first = 2 * (int(settings.bodies) if dofs < 0 else dofs) + nc
    names = law_column_names(law_layout(settings, nc))
    return {name: x[..., first + i] for i, name in enumerate(names)}


# The mechanism parameters a scenario can declare uncertain (settings m{i}_sigma, spring{i}_k_sigma,
# spring{i}_c_sigma > 0), in the order their states follow the law parameters: (the value's key pattern,
# the count key of its elements). Each estimated one is named by its value's scenario key (m2, spring1_k).
def mech_layout(sc: Any) -> Tuple[str, ...]:
    """The estimated mechanism parameters of a scenario or settings, in state order (masses, stiffnesses,
    dampers, each by element): their scenario keys (m2, spring1_k, spring3_c). They are the last states of x,
    after the law parameters; caekf-replay's columns of the same names, their variances p_<key>."""
    from .mechanism import mech_column_names, mech_layout as layout

    return mech_column_names(layout(sc))


def _mech_columns(settings: Settings, a: np.ndarray, prefix: str = "") -> Dict[str, np.ndarray]:
    """The mechanism parameters' entries of a (last axis: x or P's diagonal) by column name (prefix + key)."""
    names = mech_layout(settings)
    first = a.shape[-1] - len(names)
    return {prefix + name: a[..., first + i] for i, name in enumerate(names)}


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

    t: np.ndarray  # (steps,) [s]
    x: np.ndarray  # (steps, n) posterior [q [m], v [m/s], gamma per contact [N/m^n], law, mechanism parameters]
    P_diag: Optional[np.ndarray]  # (steps, n) diagonal of P (physical units squared)
    flags: np.ndarray  # (steps,) uint32 CAEKF_FLAG_* bits
    nis: np.ndarray  # (steps,) normalised innovation squared (0 on steps without correction)
    newton_iters: np.ndarray  # (steps,) int32
    delta: np.ndarray  # (steps,) deepest predicted penetration over the contacts [m]
    status: np.ndarray  # (steps,) int8 caekf_status_t of each call
    has_y: np.ndarray  # (steps,) bool: False where caekf_predict bridged a missing measurement
    p_norm: Optional[np.ndarray]  # (steps,) 2-norm of P, when asked for (p_norm=True)
    log_det_s: Optional[np.ndarray]  # (steps,) log det of the innovation covariance, when asked for
    settings: Settings
    dofs: int = -1  # a structure's degrees of freedom (the positions in x); -1: the settings' bodies

    @property
    def precision(self) -> str:
        return self.settings.precision

    @property
    def n(self) -> int:
        """States per step: 2 bodies + contacts."""
        return int(self.x.shape[1])

    @property
    def gamma_index(self) -> int:
        """Column of contact 1's gamma in x and P_diag (2 bodies, or 2 dofs of a structure)."""
        return _gamma_index(self.settings) if self.dofs < 0 else 2 * self.dofs

    @property
    def gamma(self) -> np.ndarray:
        """Stiffness estimate of contact 1 [N/m^n] (steps,)."""
        self._need_contact()
        return self.x[:, self.gamma_index]

    @property
    def gammas(self) -> np.ndarray:
        """Stiffness estimates of every contact [N/m^n_c] (steps, contacts)."""
        return self.x[:, self.gamma_index:self.gamma_index + int(self.settings.contacts)]

    @property
    def law(self) -> Dict[str, np.ndarray]:
        """The estimated law parameters (docs/contact-law.md) by caekf-replay's column name (n, lambda,
        gap; n2.. for contact 2): (steps,) each, after the gammas in x."""
        return _law_columns(self.settings, self.x, self.dofs)

    @property
    def mech(self) -> Dict[str, np.ndarray]:
        """The estimated mechanism parameters (settings m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma > 0)
        by caekf-replay's column name, their scenario key (m2, spring1_k, spring3_c): (steps,) each, their
        values [kg, N/m, N s/m], the last states of x."""
        return _mech_columns(self.settings, self.x)

    @property
    def p_mech(self) -> Dict[str, np.ndarray]:
        """Their variances by caekf-replay's column name (p_m2, p_spring1_k): (steps,) each; empty without
        P_diag."""
        return {} if self.P_diag is None else _mech_columns(self.settings, self.P_diag, "p_")

    @property
    def p_gg(self) -> Optional[np.ndarray]:
        """Variance of contact 1's gamma [(N/m^n)^2]."""
        self._need_contact()
        return None if self.P_diag is None else self.P_diag[:, self.gamma_index]

    def _need_contact(self) -> None:
        if self.gamma_index >= self.n:
            raise ValueError("this mechanism has no contact, so no gamma")

    @property
    def flags_seen(self) -> int:
        return int(np.bitwise_or.reduce(self.flags)) if len(self.flags) else 0

    def __len__(self) -> int:
        return len(self.t)


def _structure_tuple(st: Any) -> Tuple[Any, ...]:
    """(dofs, mass, K, C, Bu, W, H) for the C Estimator: C-contiguous float64; W and H row per contact and
    sensor (the core's layout), Bu dofs x inputs."""
    arr = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    bu = None if st.Bu.size == 0 else arr(st.Bu)
    return (int(st.M.shape[0]), arr(np.diag(st.M)), arr(st.K), arr(st.C), bu, arr(st.W.T), arr(st.H))


def _c_size(name: str, doc: str) -> property:
    """A read-only int property of Estimator: the C object's attribute `name`."""
    return property(lambda self: int(getattr(self._c, name)), doc=doc)


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

    The mechanism's sizes: `n` states (x = [q_1..q_nq, v_1..v_nq, gamma_1..gamma_nc]), `sensors`
    measurements and `inputs` forces per step, `bodies`, `contacts`, `gamma_index` (contact 1's gamma in x)
    and `gamma_indices` (every contact's).
    """

    def __init__(self, scenario_or_settings: ScenarioOrSettings, precision: Optional[str] = None,
                 experiment: Optional[str] = None, structure: Optional[Any] = None, **overrides: Any) -> None:
        s = _settings(scenario_or_settings, precision, experiment, overrides)
        c = _module(s.precision)
        d = s.to_c()
        bad = c.settings_validate(d)
        if bad is not None:
            raise SettingsError(f"settings refused: {bad[1]}")
        if structure is None:
            structure = getattr(scenario_or_settings, "structure", None)
        #: q = modal_basis @ eta when the structure was taken to its modal basis (its M not diagonal), else None
        self.modal_basis: Optional[np.ndarray] = None
        self._structure = structure
        if structure is None:
            self._c = c.Estimator(d)
        else:
            if not structure.diagonal_mass():  # the core takes a diagonal M: the modal basis is the same model
                structure, self.modal_basis = structure.modal()
            self._c = c.Estimator(d, structure=_structure_tuple(structure))
        self.settings = s
        # The C methods straight on the instance: a call costs what the C function does plus argument parsing.
        self.step = self._c.step  # type: ignore[method-assign]
        self.predict = self._c.predict  # type: ignore[method-assign]

    # Documented signatures; __init__ binds the C methods over them.
    def step(self, u: Union[float, Sequence[float], None], y: Sequence[float]) -> Report:  # pragma: no cover
        """caekf_step: the input forces u [N] (a number for a mechanism with one input, else a sequence of
        `inputs` numbers; None without inputs) and the measurements y, one per sensor [m or m/s]. A wrong
        count is a one-line ValueError, a non-number a TypeError. Non-finite values are refused by the
        estimator (status -4, flag INPUT_REJECTED, state untouched); never raises for them."""
        return self._c.step(u, y)

    def predict(self, u: Union[float, Sequence[float], None]) -> Report:  # pragma: no cover - replaced per instance
        """caekf_predict: time update without measurement (a lost sample), the input forces u as for step."""
        return self._c.predict(u)

    @property
    def precision(self) -> str:
        return self.settings.precision

    # The mechanism's sizes (int), read from the C object (caekf_get_sizes after init).
    n = _c_size("n", "States: 2 bodies + contacts.")
    sensors = _c_size("sensors", "Measurements per step (one per sensor).")
    inputs = _c_size("inputs", "Input forces per step.")
    bodies = _c_size("bodies", "Bodies (positions q and velocities v), or a structure's degrees of freedom.")
    contacts = _c_size("contacts", "Contacts (one gamma each).")

    def _dofs(self) -> int:
        """A structure's degrees of freedom, -1 for bodies on a line (the settings')."""
        return -1 if self._structure is None else int(self._c.bodies)

    @property
    def gamma_index(self) -> int:
        """Index of contact 1's gamma in x (2 bodies)."""
        return 2 * self._c.bodies

    @property
    def gamma_indices(self) -> range:
        """Indices of every contact's gamma in x: 2 bodies .. n-1."""
        return range(2 * self._c.bodies, self._c.n)

    @property
    def x(self) -> np.ndarray:
        """Augmented state (n,): [q [m], v [m/s], gamma per contact [N/m^n]] (caekf_get_state)."""
        out = np.empty(self._c.n)
        self._c._state_into(out)
        return out

    @property
    def gamma(self) -> float:
        """Stiffness estimate of contact 1 [N/m^n] (caekf_get_gamma); ValueError without contacts."""
        return self._c.gamma

    @property
    def gammas(self) -> np.ndarray:
        """Stiffness estimates of every contact [N/m^n_c] (contacts,)."""
        return self.x[self.gamma_index:self.gamma_index + self._c.contacts]

    @property
    def law(self) -> Dict[str, float]:
        """The estimated law parameters by column name (n, lambda, gap; n2.. for contact 2)."""
        return {k: float(v) for k, v in _law_columns(self.settings, self.x, self._dofs()).items()}

    @property
    def mech(self) -> Dict[str, float]:
        """The estimated mechanism parameters' values by column name (m2, spring1_k; see RunResult.mech)."""
        return {k: float(v) for k, v in _mech_columns(self.settings, self.x).items()}

    @property
    def P(self) -> np.ndarray:
        """Covariance (n, n) in physical units (caekf_get_covariance)."""
        n = self._c.n
        out = np.empty((n, n))
        self._c._cov_into(out)
        return out

    @property
    def p_norm(self) -> float:
        """2-norm of P in physical units (caekf_get_cov_norm2)."""
        return self._c.p_norm()

    def mismatch(self) -> Tuple[float, float]:
        """The model-mismatch monitor (caekf_get_mismatch, docs/mismatch.md): the mean NIS per sensor over
        mismatch_window steps (about 1 while consistent) and the factor now on Q_x (1 unless adapted)."""
        mean, q_scale = self._c.mismatch()
        return float(mean), float(q_scale)

    @property
    def step_count(self) -> int:
        return self._c.step_count

    @property
    def last_flags(self) -> int:
        return self._c.last_flags

    def reset(self) -> None:
        """Back to the initial estimate (caekf_init with the same settings)."""
        self._c.reset()

    def run(self, u: Optional[np.ndarray], y: np.ndarray, *, t: Optional[np.ndarray] = None,
            has_y: Optional[np.ndarray] = None, missing_y: str = "predict", p_diag: bool = True,
            p_norm: bool = False, log_det_s: bool = False) -> RunResult:
        """Continue over n samples in C from the current state; see :func:`run`."""
        ny, nu, nx = self._c.sensors, self._c.inputs, self._c.n
        y = np.ascontiguousarray(y, dtype=np.float64)
        if y.ndim != 2 or y.shape[1] != ny:
            raise ValueError(f"y must have shape (steps, {ny}) (one column per sensor), got {y.shape}")
        n = len(y)
        u = np.empty((n, 0)) if u is None and nu == 0 else np.ascontiguousarray(u, dtype=np.float64)
        if u.shape != (n, nu) and not (nu == 1 and u.shape == (n,)):
            want = f"({n},) or ({n}, 1)" if nu == 1 else f"({n}, {nu})"
            raise ValueError(f"u must have shape {want} (one column per input, a row per row of y), got {u.shape}")
        if has_y is not None:
            has = np.ascontiguousarray(has_y, dtype=np.bool_).reshape(-1)
            if len(has) != n:
                raise ValueError(f"has_y must have {n} entries, got {len(has)}")
        elif missing_y == "predict":
            has = ~np.isnan(y).all(axis=1)
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
        # The time convention (docs/discretisation.md): q0, v0 are the state at t = 0, so a first row at
        # t = 0 is corrected without a time update; otherwise the first row is one dt after the start.
        at_t0 = n > 0 and self._c.step_count == 0 and bool(has[0]) and abs(t[0]) <= 0.5 * self.settings.dt
        x = np.empty((n, nx))
        pd = np.empty((n, nx)) if p_diag else None
        flags = np.empty(n, dtype=np.uint32)
        iters = np.empty(n, dtype=np.int32)
        nis = np.empty(n)
        delta = np.empty(n)
        status = np.empty(n, dtype=np.int8)
        pn = np.empty(n) if p_norm else None
        ld = np.empty(n) if log_det_s else None
        self._c._run(u, y, None if has.all() else has, x, pd, flags, iters, nis, delta, status, pn, ld, at_t0)
        return RunResult(t=t, x=x, P_diag=pd, flags=flags, nis=nis, newton_iters=iters, delta=delta,
                         status=status, has_y=has, p_norm=pn, log_det_s=ld, settings=self.settings,
                         dofs=-1 if self._structure is None else int(self._c.bodies))

    # pickling: settings plus the raw caekf_t (same build only)
    def __getstate__(self) -> Dict[str, Any]:
        return {"settings": self.settings, "raw": self._c._get_raw(), "structure": self._structure}

    def __setstate__(self, state: Dict[str, Any]) -> None:
        self.__init__(state["settings"], structure=state.get("structure"))  # type: ignore[misc]
        self._c._set_raw(state["raw"])

    def __repr__(self) -> str:
        gammas = ", ".join(f"{g:.6g}" for g in self.gammas)
        return (f"Estimator({self.precision}, n={self.n}, mode={self.settings.mode}, gamma=[{gammas}], "
                f"steps={self.step_count})")


def run(scenario_or_settings: ScenarioOrSettings, u: Optional[np.ndarray], y: np.ndarray, *,
        t: Optional[np.ndarray] = None, precision: Optional[str] = None, experiment: Optional[str] = None,
        has_y: Optional[np.ndarray] = None, missing_y: str = "predict", p_diag: bool = True,
        p_norm: bool = False, log_det_s: bool = False, **overrides: Any) -> RunResult:
    """Run the C estimator over a whole record, the loop in C (no GIL held), from its initial estimate.

    y: (steps, sensors) measurements, one column per sensor of the mechanism [m or m/s] (the paper's:
    [q1, q4]); u: (steps, inputs) input forces [N], (steps,) for a mechanism with one input, None for one
    without inputs; t: (steps,)
    sample times [s] (default k dt, k = 1..steps). A row of y that is all NaN is a lost measurement bridged
    by caekf_predict, as `caekf-replay --missing-y-predict` does (missing_y="predict"); missing_y="reject"
    hands such rows to caekf_step, which refuses them (flag INPUT_REJECTED) like `--allow-nonfinite`.
    `has_y` (steps,) bool sets the rows explicitly. The result's x and P_diag are (steps, n) for the
    mechanism's n states; `gamma` is contact 1's, `gammas` every contact's. `p_norm` adds the 2-norm of
    P per step (costly Jacobi sweeps, as caekf-replay's p_norm column); `log_det_s` the log-determinant
    of each correction's innovation covariance (for the innovation likelihood; NaN on steps without a
    plain correction). Settings as for :class:`Estimator`.

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
    q [m], v [m/s], delta [m]); a pure function, picklable for process pools and Dask. The C truth
    integrates any mechanism the scenario describes (docs/mechanism.md)."""
    from .truth import Truth

    from .mechanism import Mechanism

    require_truth(sc)
    mech = Mechanism.from_scenario(sc)
    x = sc.t_end / sc.dt
    n = int(math.floor(x + 0.5)) if x > 0 else 0  # caekf_scenario_steps: lround
    t = np.empty(n)
    u, delta = np.empty((n, sc.inputs)), np.empty((n, sc.contacts))
    y, q, v = np.empty((n, sc.sensors)), np.empty((n, sc.bodies)), np.empty((n, sc.bodies))
    iters, failed = np.empty(n, dtype=np.int32), np.empty(n, dtype=np.int32)
    _module("double").truth(scenario_dict(sc), t, u, y, q, v, delta, iters, failed)
    return Truth(t=t, u=u[:, 0] if sc.inputs == 1 else u, y=y, q=q, v=v,
                 delta=delta[:, 0] if sc.contacts == 1 else delta, y_names=mech.sensor_names())
