"""Helpers of the mechanism tests: a dict scenario and the example scenarios."""
from __future__ import annotations

from pathlib import Path
from typing import Any

from caekf_sim.scenario import default_scenario_path, load_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


class Sc(dict):
    """A {key: value} scenario with the attributes the estimator and truth read directly (the
    general format's keys or the paper's aliases; absent keys take the format's defaults)."""

    def __getattr__(self, key: str) -> Any:
        try:
            return self[key]
        except KeyError:
            raise AttributeError(key) from None

    @property
    def n_steps(self) -> int:
        return int(round(self["t_end"] / self["dt"]))

    def replace(self, **kw: Any) -> "Sc":
        return Sc({**self, **kw})

    def values(self):  # type: ignore[override]
        return dict(self)


def example_scenario(name: str) -> Any:
    """sim/scenarios/<name>.toml as a Scenario."""
    return load_scenario(SCENARIOS / f"{name}.toml")


def paper_path() -> Path:
    return default_scenario_path()
