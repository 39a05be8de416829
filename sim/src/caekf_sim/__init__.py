"""caekf-sim: the Python side of the caekf project (see README.md).

The shipped C estimator, from Python (caekf_sim.binding): Estimator, run, settings_for.
"""

from .binding import BindingError, Estimator, Report, RunResult, SettingsError, default_settings, run, settings_for
from .settings_adapter import Settings

__version__ = "0.1.0"

__all__ = ["BindingError", "Estimator", "Report", "RunResult", "Settings", "SettingsError", "default_settings",
           "run", "settings_for"]
