"""A non-editable install (`pip install ./sim`: a wheel) works without the source tree.

The wheel is built from this checkout and installed into a fresh venv; every check then runs that venv's
`caekf-sim` / python from a folder outside the repository: the command starts, the reference scenario is the
copy packaged in the wheel (sim/CMakeLists.txt installs it), and `caekf-sim estimate` runs the C estimator
through the wheel's compiled binding and writes the same estimate as this checkout's own (editable) package.

How, and why so (no network, nothing but the project venv):
- `pip wheel --no-deps --no-build-isolation --no-index ./sim` with the project venv's interpreter: the same
  build as `pip install ./sim` (scikit-build-core, with the system cmake and compiler), but the backend comes
  from the project venv (the dev extra holds it) instead of being downloaded into an isolated build env.
- `python -m venv --without-pip` by the same interpreter, and the wheel installed into it with the project
  venv's pip (`pip --python NEW install --no-deps --no-index`).
- The runtime dependencies (numpy, scipy, tqdm) are the project venv's: a .pth line in the new venv appends
  the project venv's site-packages to sys.path, after the new venv's own. `--system-site-packages` would not
  do: they are not in the system's Python. `pip install --target` with PYTHONPATH under the project venv's
  interpreter would not either: the project venv's editable-install hook (a .pth that imports a finder)
  could serve caekf_sim from sim/src. A path appended by a .pth is not a site directory, so the .pth files
  in it (that hook) are never run, and the new venv's own caekf_sim comes first.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from caekf_sim.cli import main
from caekf_sim.scenario import default_scenario_path, load_scenario

SIM = Path(__file__).resolve().parents[1]
REPO = SIM.parent
STEPS = 400


def _run(cmd: list, cwd: Path, env: dict, what: str) -> subprocess.CompletedProcess:
    res = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True)
    assert res.returncode == 0, f"{what} failed ({res.returncode}):\n{res.stdout[-3000:]}\n{res.stderr[-3000:]}"
    return res


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> dict:
    """The venv with the wheel installed: its folder, a clean environment and a working folder outside the repo."""
    root = tmp_path_factory.mktemp("install")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV") and not k.startswith("CAEKF_")}
    env.update(PIP_DISABLE_PIP_VERSION_CHECK="1", PIP_NO_INPUT="1")
    wheels = root / "wheels"
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "--no-index",
          "-w", wheels, SIM], REPO, env, "pip wheel ./sim")
    wheel = sorted(wheels.glob("caekf_sim-*.whl"))
    assert len(wheel) == 1, f"expected one caekf_sim wheel, got {[w.name for w in wheels.iterdir()]}"
    venv = root / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", venv], root, env, "venv")
    py = venv / "bin" / "python"
    _run([sys.executable, "-m", "pip", "--python", py, "install", "-q", "--no-deps", "--no-index", wheel[0]],
         root, env, "pip install <wheel>")
    site = Path(_run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], root, env,
                     "venv site-packages").stdout.strip())
    (site / "caekf_deps_from_project_venv.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    work = root / "work"
    work.mkdir()
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    return {"venv": venv, "py": py, "site": site, "env": env, "work": work}


def test_version(installed):
    res = _run([installed["venv"] / "bin" / "caekf-sim", "--version"], installed["work"], installed["env"],
               "caekf-sim --version")
    assert res.stdout.startswith("caekf-sim "), res.stdout


def test_package_and_data_come_from_the_wheel(installed):
    probe = ("import caekf_sim, caekf_sim._caekf_double as d, caekf_sim._caekf_float as f\n"
             "from caekf_sim.scenario import default_scenario_path\n"
             "print(caekf_sim.__file__); print(d.__file__); print(f.__file__); print(default_scenario_path())\n")
    res = _run([installed["py"], "-c", probe], installed["work"], installed["env"], "import from the wheel")
    paths = [Path(p) for p in res.stdout.split()]
    assert len(paths) == 4, res.stdout
    for p in paths:
        assert p.is_relative_to(installed["site"] / "caekf_sim"), f"{p} is not the installed package's"
    assert paths[3].name == "paper.toml"
    assert paths[3].read_text() == (SIM / "scenarios" / "paper.toml").read_text()


def test_estimate_runs_the_packaged_c_estimator(installed, tmp_path):
    dt = load_scenario(default_scenario_path()).dt
    meas = installed["work"] / "meas.csv"
    rows = ["t,u,y1,y4"]
    for k in range(STEPS):
        t = k * dt
        rows.append(f"{t!r},{10.0 * math.sin(2 * math.pi * 3 * t)!r},{1e-3 * math.sin(2 * math.pi * t)!r},"
                    f"{2e-3 * math.sin(2 * math.pi * 2 * t)!r}")
    meas.write_text("\n".join(rows) + "\n")
    out = installed["work"] / "est.csv"
    _run([installed["venv"] / "bin" / "caekf-sim", "estimate", "--measurements", meas.name, "--engine", "c",
          "--out", out.name, "--no-progress"], installed["work"], installed["env"], "caekf-sim estimate")
    lines = out.read_text().splitlines()
    assert lines[0].startswith("t,q1,") and len(lines) == STEPS + 1
    assert all(math.isfinite(float(v)) for v in lines[-1].split(","))
    # The same estimate as this checkout's package (the same C, the same compiler flags): bit for bit.
    ref = tmp_path / "ref.csv"
    assert main(["estimate", "--measurements", str(meas), "--engine", "c", "--out", str(ref),
                 "--no-progress"]) == 0
    assert out.read_text() == ref.read_text()
