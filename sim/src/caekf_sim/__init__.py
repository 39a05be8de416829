"""caekf-sim: the Python side of the caekf project (see README.md).

The shipped C estimator, from Python (caekf_sim.binding): Estimator, run, settings_for.
"""

from .binding import BindingError, Estimator, Report, RunResult, SettingsError, default_settings, run, settings_for
from .settings_adapter import Settings


def _version() -> str:
    """The installed distribution's version: CMake's project version (sim/pyproject.toml reads it), one source."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("caekf-sim")
    except PackageNotFoundError:  # not installed (imported from the source tree)
        return "unknown"


__version__ = _version()

__all__ = ["BindingError", "Estimator", "Report", "RunResult", "Settings", "SettingsError", "default_settings",
           "run", "settings_for"]
