"""The model-mismatch monitor seen from the binding (docs/mismatch.md): a run that diverges under a model
that does not fit ends in rolled-back steps, and those still say what the monitor says. Before, a
rolled-back step's flags lacked MODEL_MISMATCH, so 18 of the 200 runs of the mismatch family (seed
20261207) ended 'silently wrong' with gamma negative and the monitor's mean far above its ratio."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from caekf_sim import flags as fl
from caekf_sim.binding import Estimator
from caekf_sim.campaign.runner import filter_inputs, truth_arrays
from caekf_sim.campaign.spec import load_spec

SPEC = Path(__file__).resolve().parents[1] / "families" / "mismatch.toml"


def test_a_rolled_back_step_carries_the_mismatch_flag():
    run = load_spec(SPEC, runs=5, seed=20261207).runs[4]  # diverges to a negative gamma, then rolls back
    tr = truth_arrays(run.truth_scenario())
    u = filter_inputs(run, tr)
    est = Estimator(run.scenario, mismatch_adapt=1)  # the way out on: it lets this run's gamma go, and diverge
    rolled_back = 0
    for k in range(len(tr.t)):
        rep = est.step(float(u[k]), tr.y[k])
        mean, q_scale = est.mismatch()
        if rep.status != 0:
            rolled_back += 1
            assert rep.flags & fl.NUMERIC_ROLLBACK
            assert bool(rep.flags & fl.MODEL_MISMATCH) == bool(mean > 3.0 or q_scale > 1.0), k
    assert rolled_back > 0, "the run no longer rolls back: pick another run of the family"
    assert rep.flags & fl.MODEL_MISMATCH
    assert np.isfinite(mean)


def test_the_estimators_sizes_with_law_and_mechanism_parameters():
    """Estimator.bodies and gamma_index count the bodies, not (n - contacts) / 2: with the law's and the
    mechanism's parameters in the state the latter read 10 bodies of the paper's 4 and gamma at index 20."""
    est = Estimator(Path(__file__).resolve().parents[1] / "scenarios" / "paper.toml", contact1_estimate_n=1,
                    contact1_sigma_n0=0.1, m2_sigma=0.03, spring1_k_sigma=0.03)
    assert (est.bodies, est.contacts, est.n) == (4, 1, 2 * 4 + 1 + 1 + 2)
    assert est.gamma_index == 8
    assert est.gamma == est.x[est.gamma_index]
