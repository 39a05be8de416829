"""Per-step health/status bits written in the `flags` column of an estimate CSV."""
from __future__ import annotations

from typing import List

CONTACT_ACTIVE = 1 << 0  # predicted delta(x_k^-) > 0 (eq. 21): gamma is observable this step
CONSTRAINT_APPLIED = 1 << 1  # gamma < gamma_min after correction: eqs. (28)-(30) re-correction
NEWTON_FAILED = 1 << 2  # prediction Newton hit its iteration limit or a singular Jacobian
NON_FINITE = 1 << 3  # NaN/Inf in the state or P
CONSTRAINT_PINV = 1 << 4  # the constrained innovation covariance was singular: pinv fallback

NAMES = {
    CONTACT_ACTIVE: "contact",
    CONSTRAINT_APPLIED: "constraint",
    NEWTON_FAILED: "newton_fail",
    NON_FINITE: "non_finite",
    CONSTRAINT_PINV: "constraint_pinv",
}


def describe(bits: int) -> List[str]:
    """Names of the bits set in `bits`, lowest first."""
    return [name for bit, name in NAMES.items() if bits & bit]
