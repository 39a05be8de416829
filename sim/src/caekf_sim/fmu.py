"""The caekf FMUs (fmu/, docs/fmu.md) driven by FMPy: a recording into the estimator FMU, or the plant FMU and
the estimator FMU as one co-simulation, and the throughput benchmark beside caekf_sim.run.

    python -m caekf_sim.fmu bench [--build-dir DIR] [--t-end S] [--experiment PRESET]

prints a table of steps per second (plant + estimator at the scenario's dt through FMPy, FMI 3.0 and 2.0;
the estimator FMU alone on the plant's samples; caekf_sim.run on the same samples).
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from . import schema

REPO = Path(__file__).resolve().parents[3]
OUTPUTS_REPLAY = ("q", "v", "gamma", "var_gamma", "p_norm", "nis", "flags", "newton_iters", "status")


def fmu_dirs(build_dir: Optional[Path] = None) -> List[Path]:
    """Where the built FMUs are looked up: build_dir/fmu, $CAEKF_BUILD_DIR/fmu, build/host-double/fmu."""
    dirs = [Path(build_dir) / "fmu"] if build_dir else []
    if os.environ.get("CAEKF_BUILD_DIR"):
        dirs.append(Path(os.environ["CAEKF_BUILD_DIR"]) / "fmu")
    dirs.append(REPO / "build" / "host-double" / "fmu")
    return dirs


def find_fmu(role: str, version: int, build_dir: Optional[Path] = None) -> Optional[Path]:
    """caekf_<role>_fmi<version>.fmu of the first build that has it, or None."""
    for d in fmu_dirs(build_dir):
        p = d / f"caekf_{role}_fmi{version}.fmu"
        if p.is_file():
            return p
    return None


def preset_parameters(preset: Optional[str]) -> Dict[str, float]:
    """A preset of the schema as estimator FMU parameters (its settings' keys), empty for None (the default)."""
    if preset is None:
        return {}
    return {schema.SCHEMA.by_name(name).keys[0]: v for name, v in schema.preset(preset).values.items()}


class Slave:
    """One co-simulation instance of an FMU through FMPy's FMU2Slave or FMU3Slave, its variables by name.

    parameters: name -> value, set before initialisation (each by its FMI type)."""

    def __init__(self, path: Path, name: str, parameters: Optional[Dict[str, float]] = None,
                 start_time: float = 0.0, unzip_dir: Optional[str] = None) -> None:
        from fmpy import extract, read_model_description  # type: ignore[import-untyped]
        from fmpy.fmi2 import FMU2Slave  # type: ignore[import-untyped]
        from fmpy.fmi3 import FMU3Slave  # type: ignore[import-untyped]

        self.md = read_model_description(str(path))
        self._own_dir = unzip_dir is None
        self.unzip_dir = unzip_dir or extract(str(path))
        self.fmi3 = self.md.fmiVersion.startswith("3")
        self.vars = {v.name: v for v in self.md.modelVariables}
        cls = FMU3Slave if self.fmi3 else FMU2Slave
        self.fmu = cls(guid=self.md.instantiationToken if self.fmi3 else self.md.guid, unzipDirectory=self.unzip_dir,
                       modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate()
        if self.fmi3:
            self.fmu.enterInitializationMode(startTime=start_time)
        else:
            self.fmu.setupExperiment(startTime=start_time)
            self.fmu.enterInitializationMode()
        for k, v in (parameters or {}).items():
            self.set({k: v})
        self.fmu.exitInitializationMode()
        self.dt = float(self.get(["dt"])[0])
        self.t = start_time

    def vrs(self, names: Sequence[str]) -> List[int]:
        return [self.vars[n].valueReference for n in names]

    def set(self, values: Dict[str, float]) -> None:
        for name, value in values.items():
            var = self.vars[name]
            vr = [var.valueReference]
            if var.type in ("Real", "Float64"):
                (self.fmu.setFloat64 if self.fmi3 else self.fmu.setReal)(vr, [float(value)])
            elif var.type == "Boolean":
                self.fmu.setBoolean(vr, [bool(value)])
            elif var.type == "Enumeration" and self.fmi3:
                self.fmu.setInt64(vr, [int(value)])
            else:
                (self.fmu.setInt32 if self.fmi3 else self.fmu.setInteger)(vr, [int(value)])

    def get(self, names: Sequence[str]) -> List[float]:
        out = []
        for name in names:
            var = self.vars[name]
            vr = [var.valueReference]
            if var.type in ("Real", "Float64"):
                out.append((self.fmu.getFloat64 if self.fmi3 else self.fmu.getReal)(vr)[0])
            elif var.type == "Boolean":
                out.append(float(self.fmu.getBoolean(vr)[0]))
            elif var.type == "Enumeration" and self.fmi3:
                out.append(float(self.fmu.getInt64(vr)[0]))
            else:
                out.append(float((self.fmu.getInt32 if self.fmi3 else self.fmu.getInteger)(vr)[0]))
        return out

    # the fast path of the step loops: one call per type
    def set_real(self, vrs: List[int], values: Sequence[float]) -> None:
        (self.fmu.setFloat64 if self.fmi3 else self.fmu.setReal)(vrs, list(values))

    def get_real(self, vrs: List[int]) -> List[float]:
        return list((self.fmu.getFloat64 if self.fmi3 else self.fmu.getReal)(vrs))

    def get_int(self, vrs: List[int]) -> List[int]:
        return list((self.fmu.getInt32 if self.fmi3 else self.fmu.getInteger)(vrs))

    def do_step(self) -> None:
        self.fmu.doStep(currentCommunicationPoint=self.t, communicationStepSize=self.dt)
        self.t += self.dt

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()
        if self._own_dir:
            shutil.rmtree(self.unzip_dir, ignore_errors=True)


def _output_names(est: Slave) -> Dict[str, List[str]]:
    nq, nc = int(est.get(["bodies"])[0]), int(est.get(["contacts"])[0])
    real = [f"q{i + 1}" for i in range(nq)] + [f"v{i + 1}" for i in range(nq)]
    real += [f"gamma{c + 1}" for c in range(nc)] + [f"var_gamma{c + 1}" for c in range(nc)] + ["p_norm", "nis"]
    return {"real": real, "int": ["flags", "newton_iters", "status"]}


def _collect(rows: List[List[float]], names: List[str]) -> Dict[str, np.ndarray]:
    a = np.array(rows, dtype=np.float64).reshape(len(rows), len(names))
    return {n: a[:, i] for i, n in enumerate(names)}


def replay(path: Path, t: np.ndarray, u: np.ndarray, y: np.ndarray, has_y: Optional[np.ndarray] = None,
           preset: Optional[str] = None, parameters: Optional[Dict[str, float]] = None) -> Dict[str, np.ndarray]:
    """The estimator FMU over a recording (rows at t, u (steps, inputs), y (steps, sensors)), as caekf-replay
    reads it: the scenario's q0, v0 are the state at t = 0, so a first row at t = 0 is that communication
    point's sample, any other first row one dt later (the FMU then starts with a communication step without a
    sample). has_y: rows whose sensors are valid (default all). Returns each output per row."""
    u = np.asarray(u, dtype=np.float64).reshape(len(t), -1)
    y = np.asarray(y, dtype=np.float64).reshape(len(t), -1)
    has = np.ones(len(t), dtype=bool) if has_y is None else np.asarray(has_y, dtype=bool)
    est = Slave(path, "estimator", {**preset_parameters(preset), **(parameters or {})})
    try:
        names = _output_names(est)
        ni, ns = u.shape[1], y.shape[1]
        in_vrs = est.vrs([f"u{i + 1}" for i in range(ni)] + [f"y{j + 1}" for j in range(ns)])
        valid_vrs = est.vrs([f"y{j + 1}_valid" for j in range(ns)])
        real_vrs, int_vrs = est.vrs(names["real"]), est.vrs(names["int"])
        if abs(t[0]) > 0.5 * est.dt:  # the recording starts one dt after the estimate's t = 0
            est.fmu.setBoolean(valid_vrs, [False] * ns)
            est.do_step()
        valid = None
        reals: List[List[float]] = []
        ints: List[List[int]] = []
        for k in range(len(t)):
            est.set_real(in_vrs, list(u[k]) + list(y[k]))
            if has[k] != valid:
                valid = bool(has[k])
                est.fmu.setBoolean(valid_vrs, [valid] * ns)
            est.do_step()
            reals.append(est.get_real(real_vrs))
            ints.append(est.get_int(int_vrs))
        out = _collect(reals, names["real"])
        out.update(_collect([list(map(float, r)) for r in ints], names["int"]))
        return out
    finally:
        est.close()


def cosimulate(plant_path: Path, estimator_path: Path, t_end: float, preset: Optional[str] = None,
               parameters: Optional[Dict[str, float]] = None) -> Dict[str, np.ndarray]:
    """The plant FMU and the estimator FMU as one co-simulation at the scenario's dt (the master of
    docs/fmu.md): at each communication point the plant's u and y (and y_valid) go to the estimator, then
    both step. Returns the plant's samples (t, u1.., y1.., q1.., delta1..) and the estimator's outputs at the
    samples t = k dt, k = 1 .. round(t_end / dt)."""
    plant = Slave(plant_path, "plant")
    est = Slave(estimator_path, "estimator", {**preset_parameters(preset), **(parameters or {})})
    try:
        ni, ns = int(plant.get(["inputs"])[0]), int(plant.get(["sensors"])[0])
        nq, nc = int(plant.get(["bodies"])[0]), int(plant.get(["contacts"])[0])
        sig = [f"u{i + 1}" for i in range(ni)] + [f"y{j + 1}" for j in range(ns)]
        p_out = plant.vrs(sig + [f"q{i + 1}" for i in range(nq)] + [f"delta{c + 1}" for c in range(nc)])
        p_valid = plant.vrs(["y_valid"])
        e_in = est.vrs(sig)
        e_valid = est.vrs([f"y{j + 1}_valid" for j in range(ns)])
        names = _output_names(est)
        real_vrs, int_vrs = est.vrs(names["real"]), est.vrs(names["int"])
        steps = int(round(t_end / plant.dt))
        plant_rows: List[List[float]] = []
        reals: List[List[float]] = []
        ints: List[List[int]] = []
        valid = None
        for k in range(steps + 1):
            p = plant.get_real(p_out)
            v = bool(plant.fmu.getBoolean(p_valid)[0])
            est.set_real(e_in, p[:ni + ns])
            if v != valid:
                valid = v
                est.fmu.setBoolean(e_valid, [v] * ns)
            est.do_step()
            if k > 0:  # the samples: the estimate of communication point k dt
                plant_rows.append([k * plant.dt] + p)
                reals.append(est.get_real(real_vrs))
                ints.append(est.get_int(int_vrs))
            if k < steps:
                plant.do_step()
        truth_names = sig + [f"q{i + 1}" for i in range(nq)] + [f"delta{c + 1}" for c in range(nc)]
        out = _collect(plant_rows, ["t"] + truth_names)
        out.update({f"est_{k}": v for k, v in _collect(reals, names["real"]).items()})
        out.update({f"est_{k}": v for k, v in _collect([list(map(float, r)) for r in ints], names["int"]).items()})
        return out
    finally:
        est.close()
        plant.close()


def bench(build_dir: Optional[Path] = None, t_end: float = 20.0, experiment: Optional[str] = "switched") -> str:
    """Steps per second of plant + estimator through FMPy (FMI 3.0 and 2.0), of the estimator FMU alone on
    the plant's samples, and of caekf_sim.run on the same samples; one table."""
    from .scenario import default_scenario_path, load_scenario
    from . import binding

    rows: List[List[Any]] = []
    samples = None
    for v in (3, 2):
        plant, est = find_fmu("plant", v, build_dir), find_fmu("estimator", v, build_dir)
        if plant is None or est is None:
            raise SystemExit(f"FMI {v}.0 FMUs not built (looked in {', '.join(map(str, fmu_dirs(build_dir)))}): "
                             "cmake --build --preset host-double")
        t0 = time.perf_counter()
        res = cosimulate(plant, est, t_end, preset=experiment)
        wall = time.perf_counter() - t0
        n = len(res["t"])
        rows.append([f"plant + estimator FMU, FMI {v}.0, FMPy master loop", n, wall])
        samples = res
        t0 = time.perf_counter()
        replay(est, res["t"], res["u1"], np.column_stack([res["y1"], res["y2"]]), preset=experiment)
        rows.append([f"estimator FMU alone, FMI {v}.0, FMPy", n, time.perf_counter() - t0])
    assert samples is not None
    sc = load_scenario(default_scenario_path())
    y = np.column_stack([samples["y1"], samples["y2"]])
    t0 = time.perf_counter()
    binding.run(sc, samples["u1"], y, experiment=experiment, p_norm=True)
    rows.append(["caekf_sim.run (C loop, binding)", len(y), time.perf_counter() - t0])
    dt = sc.dt
    head = ["what", "steps", "wall [s]", "steps/s", "us/step", "x real time"]
    cells = [head] + [[r[0], str(r[1]), f"{r[2]:.3f}", f"{r[1] / r[2]:.0f}", f"{1e6 * r[2] / r[1]:.1f}",
                       f"{r[1] * dt / r[2]:.1f}"] for r in rows]
    w = [max(len(c[i]) for c in cells) for i in range(len(head))]
    lines = ["  ".join(c[i].ljust(w[i]) if i == 0 else c[i].rjust(w[i]) for i in range(len(head))) for c in cells]
    lines.insert(1, "  ".join("-" * x for x in w))
    return "\n".join([f"co-simulation throughput, dt = {dt * 1e3:g} ms, {t_end:g} s of the reference scenario, "
                      f"preset {experiment or 'default'}"] + lines)


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m caekf_sim.fmu", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("bench", help="co-simulation throughput through FMPy beside caekf_sim.run")
    b.add_argument("--build-dir", type=Path, default=None, help="CMake build folder (default: host-double's)")
    b.add_argument("--t-end", type=float, default=20.0, help="simulated seconds (default 20)")
    b.add_argument("--experiment", default="switched", help="preset of the estimator (default switched)")
    a = ap.parse_args(argv)
    print(bench(a.build_dir, a.t_end, a.experiment))
    return 0


if __name__ == "__main__":
    sys.exit(main())
