"""Per-step health/status bits of the `flags` column: the C core's bit layout (caekf.h).

Bits this numpy reference never sets (it has no input screening, repair or rollback) keep
their C meaning so that CSVs from both sides read the same way. NON_FINITE is numpy-only.
"""
from __future__ import annotations

from typing import List

NEWTON_NOT_CONVERGED = 1 << 0  # prediction Newton hit its iteration bound or a singular Jacobian
INPUT_REJECTED = 1 << 1  # (C only) non-finite u or y refused
CONSTRAINT_APPLIED = 1 << 2  # gamma < gamma_min after correction: eqs. (28)-(30) applied
CONTACT_ACTIVE = 1 << 3  # predicted delta(x_k^-) > 0 (eq. 21)
COV_REPAIRED = 1 << 4  # (C only) P repaired after losing PSD
SINGULAR_INNOVATION = 1 << 5  # constrained S^c singular: pseudo-inverse gain used here
CONSTRAINT_CLAMPED = 1 << 6  # (C only) perfect measurement refused, gamma clamped
NUMERIC_ROLLBACK = 1 << 7  # (C only) non-finite result rolled back
GAMMA_FROZEN = 1 << 8  # switched mode, contact inactive: gamma and P_gg frozen
COV_INDEFINITE = 1 << 9  # (C only) P failed the PSD test
NO_MEASUREMENT = 1 << 10  # (C only) prediction-only step (caekf_predict, lost measurement)
GAMMA_GATED = 1 << 11  # (C only) innovation above gamma_gate_nis: gamma held this step
NON_FINITE = 1 << 16  # (numpy only) NaN/Inf in the state or P after the step

NAMES = {
    NEWTON_NOT_CONVERGED: "newton_not_converged",
    INPUT_REJECTED: "input_rejected",
    CONSTRAINT_APPLIED: "constraint_applied",
    CONTACT_ACTIVE: "contact_active",
    COV_REPAIRED: "cov_repaired",
    SINGULAR_INNOVATION: "singular_innovation",
    CONSTRAINT_CLAMPED: "constraint_clamped",
    NUMERIC_ROLLBACK: "numeric_rollback",
    GAMMA_FROZEN: "gamma_frozen",
    COV_INDEFINITE: "cov_indefinite",
    NO_MEASUREMENT: "no_measurement",
    GAMMA_GATED: "gamma_gated",
    NON_FINITE: "non_finite",
}


def describe(bits: int) -> List[str]:
    """Names of the bits set in `bits`, lowest first."""
    return [name for bit, name in NAMES.items() if bits & bit]
