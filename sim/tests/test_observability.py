"""PBH test of eq. (20): the paper's two observability claims (Sec. 3.2)."""
import numpy as np

from caekf_sim.model import Plant
from caekf_sim.observability import analyse, augmented_jacobian, gamma_in_unobservable_subspace, pbh


def test_contact_active_is_observable_even_with_one_sensor(sc):
    res = analyse(sc, penetration=2e-6)
    for sensors in (("q1", "q4"), ("q1",), ("q4",)):
        r = res[("active", sensors)]
        assert r.observable, sensors
        assert min(row.sigma_min_rel for row in r.rows) > 1e-6  # well clear of the rank tolerance


def test_contact_inactive_is_unobservable_in_gammas_mode(sc):
    res = analyse(sc, penetration=2e-6)
    r = res[("inactive", ("q1", "q4"))]
    assert not r.observable
    assert [abs(row.eigenvalue) for row in r.deficient] == [0.0]  # only lambda = 0 ...
    assert r.deficient[0].rank == 8 and r.deficient[0].sigma_min_rel < 1e-12
    assert gamma_in_unobservable_subspace(sc) > 1 - 1e-12  # ... and its null vector is gamma alone


def test_single_sensor_without_contact_also_loses_the_other_pair(sc):
    """Without contact the chain splits: q1 alone cannot see bodies 3-4 (two extra modes)."""
    r = analyse(sc, penetration=2e-6)[("inactive", ("q1",))]
    assert len(r.deficient) == 1 + 4  # gamma's mode + two complex-conjugate pairs


def test_jacobian_gamma_column_is_the_contact_sensitivity(sc):
    plant = Plant.from_scenario(sc)
    d = 2e-6
    A = augmented_jacobian(plant, d, sc.gamma)
    np.testing.assert_allclose(A[4:8, 8], -np.array([0, 1, -1, 0]) * d**1.5 / plant.m)
    assert np.all(augmented_jacobian(plant, -d, sc.gamma)[:, 8] == 0)


def test_pbh_detects_an_obviously_unobservable_pair():
    A = np.diag([-1.0, -2.0])
    assert [r.rank for r in pbh(A, np.array([[1.0, 0.0]]))] == [2, 1]
