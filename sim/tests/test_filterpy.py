"""FilterPy's ExtendedKalmanFilter, given the same F and H, reproduces the canonical run."""
import pytest

pytest.importorskip("filterpy")

from caekf_sim.filterpy_check import compare, run_filterpy  # noqa: E402
from caekf_sim.experiments import experiment_config  # noqa: E402


def test_filterpy_reproduces_canonical(sc, truth, results):
    xs, Ps = run_filterpy(sc, truth, experiment_config("canonical"))
    a = compare(xs, Ps, results["canonical"], sc.gamma)
    assert a.state_rel < 1e-8
    assert a.gamma_rel < 1e-8
    assert a.p_rel < 1e-7
