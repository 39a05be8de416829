"""A recording's inputs for the tests: the reference scenario stripped of every truth-only key (what a user
writes for a real mechanism) and a short measurement CSV (t, u, y1, y4) of the reference scenario's truth."""
from __future__ import annotations

import re
from pathlib import Path
from typing import List

import numpy as np

from caekf_sim.scenario import canonical, default_scenario_path, load_scenario, parse_flat
from caekf_sim.schema import SCHEMA, setting_of
from caekf_sim.truth import simulate

REPO = Path(__file__).resolve().parents[2]
PAPER = default_scenario_path()


def truth_keys_in_use() -> List[str]:
    """The truth-only keys without a default that the reference scenario's mechanism uses (contact1_gamma,
    input1_amp, ..., t_end, seed): the ones a truth simulation needs."""
    values = load_scenario(PAPER).values()
    return [k for k, s, i in SCHEMA.keys()
            if s.kind == "truth" and s.element_required(i) and SCHEMA.in_use(s, i, values)]


def _key(line: str) -> str:
    return line.split("#", 1)[0].partition("=")[0].strip()


def text_without(keys: List[str]) -> str:
    """The reference scenario's text without the lines giving `keys` (canonical keys; a paper alias in the file,
    `gamma` for contact1_gamma, counts as its key)."""
    return "\n".join(ln for ln in PAPER.read_text().splitlines()
                     if not (_key(ln) and canonical(_key(ln)) in keys)) + "\n"


def write_scenario_without_truth(path: Path) -> Path:
    """The reference scenario with no truth-only key at all (checked: none is left)."""
    text = "\n".join(ln for ln in PAPER.read_text().splitlines()
                     if not (_key(ln) and setting_of(_key(ln)).kind == "truth")) + "\n"
    assert not any(setting_of(k).kind == "truth" for k in parse_flat(text))
    path.write_text(text)
    return path


def write_recording(path: Path, t_end: float = 0.3) -> Path:
    """A short measurement CSV (t,u,y1,y4) of the reference scenario's truth: what a logger records."""
    tr = simulate(load_scenario(PAPER).replace(t_end=t_end))
    np.savetxt(path, np.column_stack([tr.t, tr.u, tr.y]), delimiter=",", header="t,u,y1,y4", comments="",
               fmt="%.17g")
    return path


def project_version() -> str:
    """The project version's one source: project(caekf VERSION x.y.z) in the top-level CMakeLists.txt."""
    m = re.search(r"project\(caekf VERSION ([0-9][0-9.]*)", (REPO / "CMakeLists.txt").read_text())
    assert m is not None
    return m.group(1)
