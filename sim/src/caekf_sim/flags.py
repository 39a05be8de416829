"""Per-step health bits of the `flags` column, from the schema's [[flag]] entries (the C core's
caekf/caekf_status.h is generated from the same entries).

Bits this numpy reference never sets (it has no input screening, repair or rollback) keep their C
meaning, so that CSVs from both sides read the same way. NON_FINITE is the reference's own
(layer "reference").
"""
from __future__ import annotations

from typing import Dict, List, Optional

import numpy as np

from .schema import SCHEMA

# bit mask -> name, lowest bit first
NAMES: Dict[int, str] = {f.mask: f.name for f in SCHEMA.flags}
_MASK: Dict[str, int] = {name: mask for mask, name in NAMES.items()}


def mask(name: str) -> int:
    """The bit mask of a flag by its schema name; KeyError for an unknown one."""
    return _MASK[name]


# The flags this package's code tests or sets, by name.
NEWTON_NOT_CONVERGED = mask("newton_not_converged")
INPUT_REJECTED = mask("input_rejected")
CONSTRAINT_APPLIED = mask("constraint_applied")
CONTACT_ACTIVE = mask("contact_active")
SINGULAR_INNOVATION = mask("singular_innovation")
NUMERIC_ROLLBACK = mask("numeric_rollback")
GAMMA_FROZEN = mask("gamma_frozen")
NO_MEASUREMENT = mask("no_measurement")
GAMMA_GATED = mask("gamma_gated")
MODEL_MISMATCH = mask("model_mismatch")
NON_FINITE = mask("non_finite")
# Every bit the C core can set (the reference's own lie above them).
CORE_MASK = sum(f.mask for f in SCHEMA.core_flags)


def describe(bits: int) -> List[str]:
    """Names of the bits set in `bits`, lowest first."""
    return [name for bit, name in NAMES.items() if bits & bit]


def mismatch_words(t: np.ndarray, flags: np.ndarray) -> Optional[str]:
    """The model-mismatch monitor in words (docs/mismatch.md): None when the run ends without MODEL_MISMATCH,
    else one line saying since when the model has not fitted the data and what to do about it."""
    flagged = (np.asarray(flags).astype(np.int64) & MODEL_MISMATCH) != 0
    if len(flagged) == 0 or not flagged[-1]:
        return None
    clear = np.flatnonzero(~flagged)
    since = t[clear[-1] + 1] if len(clear) else t[0]
    return (f"model mismatch: the innovations have not fitted the model since t = {since:.3f} s "
            f"({100 * flagged.mean():.0f} % of the run); the estimate is not to be trusted as it stands: declare "
            "what is uncertain (m<i>_sigma, spring<i>_k_sigma, spring<i>_c_sigma, input<i>_sigma) or tune the noise "
            "(caekf-sim tune)")
