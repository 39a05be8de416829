"""A linear structure as matrices, and its folder format (a manifest `structure.toml` plus CSV files).

    M q'' + C q' + K q + sum_c w_c f_c = B_u u,   delta_c = w_c^T q - gap_c,

sensor i reads h_i^T q, h_i^T q' or h_i^T q'' (its kind is the scenario's, not the structure's). The manifest:

    mass = "M.csv"          # n x n, symmetric positive definite
    stiffness = "K.csv"     # n x n, symmetric
    damping = "C.csv"       # n x n, symmetric; OR rayleigh = [alpha, beta] (C = alpha M + beta K); OR neither (C = 0)
    inputs = "Bu.csv"       # n x inputs, column k is input k's load vector (optional: no inputs)
    contacts = "W.csv"      # n x contacts, column c is w_c
    sensors = "H.csv"       # sensors x n, row i is h_i

File names are relative to the folder. A CSV holds plain comma-separated numbers, one matrix row a line, no
header; lines starting with '#' and blank lines are skipped (numpy.savetxt(delimiter=",") or MATLAB's
writematrix write it). A column vector is one number a line. Errors name the file and, for an entry, its
(row, column), 1-based as the numbers stand in the file (comment lines not counted); a line number counts
every line of the file.

K need not be positive semi-definite (a structure may be held by its contacts only); what the C core needs is
a nonsingular Newton matrix M/h + C + h K, which depends on the step h and is not checked here.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Tuple

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

MANIFEST = "structure.toml"
FILE_KEYS = ("mass", "stiffness", "damping", "inputs", "contacts", "sensors")
REQUIRED_KEYS = ("mass", "stiffness", "contacts", "sensors")
KNOWN_KEYS = (*FILE_KEYS, "rayleigh")
# The file names write_structure uses, per matrix.
DEFAULT_FILES = {"mass": "M.csv", "stiffness": "K.csv", "damping": "C.csv", "inputs": "Bu.csv",
                 "contacts": "W.csv", "sensors": "H.csv"}
SYMMETRY_RTOL = 1e-9  # |A_ij - A_ji| <= SYMMETRY_RTOL * max|A|: an FE export's rounding passes, a wrong entry not

Matrix = NDArray[np.float64]


class StructureError(ValueError):
    """A structure folder or a Structure that does not hold a valid structure (one line, naming file and entry)."""


def _frozen(a: object) -> Matrix:
    """A read-only float64 copy, so a frozen Structure cannot change under its user."""
    out = np.array(a, dtype=np.float64, copy=True)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class Structure:
    """M, K, C (n x n), Bu (n x inputs), W (n x contacts), H (sensors x n); the arrays are read-only copies.

    The constructor checks the shapes only; `validate` (load_structure and write_structure call it) checks
    finiteness, symmetry and M's definiteness too."""

    M: Matrix
    K: Matrix
    C: Matrix
    Bu: Matrix
    W: Matrix
    H: Matrix

    def __post_init__(self) -> None:
        for name in ("M", "K", "C", "Bu", "W", "H"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))
        _check_shapes(self.matrices(), DEFAULT_FILES)

    def matrices(self) -> Dict[str, Matrix]:
        """Manifest key -> matrix ("mass": M, "stiffness": K, "damping": C, "inputs": Bu, ...)."""
        return dict(zip(FILE_KEYS, (self.M, self.K, self.C, self.Bu, self.W, self.H)))

    @property
    def dofs(self) -> int:
        return int(self.M.shape[0])

    @property
    def inputs(self) -> int:
        return int(self.Bu.shape[1])

    @property
    def contacts(self) -> int:
        return int(self.W.shape[1])

    @property
    def sensors(self) -> int:
        return int(self.H.shape[0])

    def diagonal_mass(self) -> bool:
        """True if M has no nonzero entry off its diagonal (what the C core takes directly)."""
        return bool(np.count_nonzero(self.M - np.diag(np.diag(self.M))) == 0)

    def modal(self) -> Tuple["Structure", Matrix]:
        """The same structure in the mass-normalised eigenbasis of (K, M), q = Phi eta; returns it and Phi.

        M = I and K = diag(omega^2) are set exactly (not the rounded Phi^T M Phi), so the C core, which needs
        a diagonal M, takes any structure this way. Modes in ascending omega^2 (negative for an unstable K)."""
        omega2, phi = scipy.linalg.eigh(self.K, self.M)
        return self._project(phi, omega2), np.asarray(phi, dtype=np.float64)

    def _project(self, phi: Matrix, omega2: Matrix) -> "Structure":
        """This structure in the coordinates eta (q = phi eta), phi mass-normalised eigenvectors."""
        c = phi.T @ self.C @ phi
        return Structure(M=np.eye(phi.shape[1]), K=np.diag(omega2), C=0.5 * (c + c.T),  # exactly symmetric
                         Bu=phi.T @ self.Bu, W=phi.T @ self.W, H=self.H @ phi)


def _check_shapes(a: Mapping[str, Matrix], files: Mapping[str, str]) -> None:
    """Every matrix in `a` (manifest key -> matrix) 2-D and sized against M; messages name the files in `files`."""
    for key, x in a.items():
        if x.ndim != 2:
            raise StructureError(f"{files[key]}: {x.ndim}-D array: must be a matrix")
    m = files["mass"]
    n = a["mass"].shape[0]
    if a["mass"].shape[1] != n:
        raise StructureError(f"{m}: {n} x {a['mass'].shape[1]}: must be square")
    for key in ("stiffness", "damping"):
        if key in a and a[key].shape != (n, n):
            raise StructureError(f"{files[key]}: {a[key].shape[0]} x {a[key].shape[1]}, but {m} is {n} x {n}")
    for key in ("inputs", "contacts"):
        if key in a and a[key].shape[0] != n:
            raise StructureError(f"{files[key]}: {a[key].shape[0]} rows, but {m} has {n}")
    if "sensors" in a and a["sensors"].shape[1] != n:
        raise StructureError(f"{files['sensors']}: {a['sensors'].shape[1]} columns, but {m} has {n} rows")


def _check_finite(name: str, a: Matrix) -> None:
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        i, j = (int(k) for k in bad[0])
        raise StructureError(f"{name}: entry ({i + 1}, {j + 1}) = {float(a[i, j])!r}: must be finite")


def _check_symmetric(name: str, a: Matrix) -> None:
    """The worst pair named, so a user fixes the entry that matters rather than a rounding."""
    diff = np.abs(a - a.T)
    r, c = (int(x) for x in np.unravel_index(int(np.argmax(diff)), diff.shape))
    i, j = min(r, c), max(r, c)
    if diff[i, j] > SYMMETRY_RTOL * float(np.max(np.abs(a))):
        raise StructureError(f"{name}: entry ({i + 1}, {j + 1}) = {float(a[i, j])!r} but ({j + 1}, {i + 1}) = "
                             f"{float(a[j, i])!r}: must be symmetric")


def _check_positive_definite(name: str, a: Matrix) -> None:
    # LAPACK's potrf reports the order of the first leading minor that fails: the row to look at.
    _, info = scipy.linalg.lapack.dpotrf(a, lower=True)
    if info > 0:
        raise StructureError(f"{name}: not positive definite (Cholesky fails at row {info})")


def _check_nonzero_columns(name: str, a: Matrix, what: str) -> None:
    """A zero w_c (or h_i) is a contact that never closes (a sensor that reads nothing): a file error."""
    zero = np.flatnonzero(~np.any(a != 0.0, axis=0))
    if zero.size:
        raise StructureError(f"{name}: {what} {int(zero[0]) + 1} is zero")


def validate(s: Structure, files: Optional[Mapping[str, str]] = None) -> None:
    """Shapes, finite entries, M, K, C symmetric, M positive definite, no zero contact or sensor.

    `files` (manifest key -> file name) is what the messages call each matrix (default: M.csv, K.csv, ...)."""
    names = {**DEFAULT_FILES, **(files or {})}
    _check_shapes(s.matrices(), names)
    for key, a in s.matrices().items():
        _check_finite(names[key], a)
    for key, a in (("mass", s.M), ("stiffness", s.K), ("damping", s.C)):
        _check_symmetric(names[key], a)
    _check_positive_definite(names["mass"], s.M)
    _check_nonzero_columns(names["contacts"], s.W, "column")
    _check_nonzero_columns(names["sensors"], s.H.T, "row")


def read_csv(path: Path, name: str) -> Matrix:
    """The numbers of a CSV as a matrix; a non-number or a ragged line is an error naming its line."""
    rows: List[List[float]] = []
    first_line = 0
    for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        row = [_number(field, name, lineno) for field in text.split(",")]
        if rows and len(row) != len(rows[0]):
            raise StructureError(f"{name}: line {lineno} has {len(row)} numbers, line {first_line} has {len(rows[0])}")
        first_line = first_line or lineno
        rows.append(row)
    if not rows:
        raise StructureError(f"{name}: no numbers")
    return np.array(rows, dtype=np.float64)


def _number(field: str, name: str, lineno: int) -> float:
    try:
        return float(field)
    except ValueError:
        raise StructureError(f"{name}: line {lineno}: cannot read {field.strip()!r} as a number") from None


def _read_manifest(folder: Path) -> Dict[str, object]:
    path = folder / MANIFEST
    if not path.is_file():
        raise StructureError(f"{MANIFEST}: not found in {folder}")
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise StructureError(f"{MANIFEST}: {exc}") from None
    for key in raw:
        if key not in KNOWN_KEYS:
            raise StructureError(f"{MANIFEST}: unknown key {key!r}")
    for key in REQUIRED_KEYS:
        if key not in raw:
            raise StructureError(f"{MANIFEST}: missing key {key!r}")
    for key in FILE_KEYS:
        if key in raw and not isinstance(raw[key], str):
            raise StructureError(f"{MANIFEST}: {key!r} must be a file name (a string)")
    if "damping" in raw and "rayleigh" in raw:
        raise StructureError(f"{MANIFEST}: 'damping' and 'rayleigh' both given: use one")
    return raw


def _rayleigh(value: object) -> Tuple[float, float]:
    ok = (isinstance(value, list) and len(value) == 2
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
    if not ok:
        raise StructureError(f"{MANIFEST}: 'rayleigh' must be [alpha, beta], two finite numbers")
    assert isinstance(value, list)
    return float(value[0]), float(value[1])


def _read_file(folder: Path, raw: Mapping[str, object], key: str) -> Matrix:
    name = str(raw[key])
    path = folder / name
    if not path.is_file():
        raise StructureError(f"{name}: file not found ({MANIFEST} key {key!r})")
    return read_csv(path, name)


def load_structure(folder: Path) -> Structure:
    """Read and validate the structure in `folder` (StructureError: one line naming file and entry)."""
    folder = Path(folder)
    raw = _read_manifest(folder)
    files = {key: str(raw[key]) for key in FILE_KEYS if key in raw}
    a = {key: _read_file(folder, raw, key) for key in files}
    _check_shapes(a, files)  # before Rayleigh's alpha M + beta K, and under the manifest's names
    n = a["mass"].shape[0]
    if "rayleigh" in raw:
        alpha, beta = _rayleigh(raw["rayleigh"])
        a["damping"] = alpha * a["mass"] + beta * a["stiffness"]
        files["damping"] = f"{MANIFEST} rayleigh"
    s = Structure(M=a["mass"], K=a["stiffness"], C=a.get("damping", np.zeros((n, n))),
                  Bu=a.get("inputs", np.zeros((n, 0))), W=a["contacts"], H=a["sensors"])
    validate(s, files)
    return s


def write_structure(folder: Path, s: Structure, comment: str = "") -> None:
    """Write `s` as a manifest and CSVs in `folder` (created), %.17g so that load_structure reads it back exactly.

    `comment` goes on top of the manifest as '#' lines. Bu.csv is written only with inputs, C.csv only with a
    nonzero C. A structure without contacts or sensors is refused (the format needs both)."""
    validate(s)
    if s.contacts == 0 or s.sensors == 0:
        raise StructureError(f"{MANIFEST}: a structure needs at least one contact and one sensor")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    lines = [f"# {line}".rstrip() for line in comment.splitlines()]
    written = (("mass", s.M, "M: mass, n x n"), ("stiffness", s.K, "K: stiffness, n x n"),
               ("damping", s.C, "C: damping, n x n"), ("inputs", s.Bu, "B_u: a column per input"),
               ("contacts", s.W, "W: a column w_c per contact"), ("sensors", s.H, "H: a row h_i per sensor"))
    for key, a, header in written:
        if (key == "inputs" and s.inputs == 0) or (key == "damping" and not np.any(s.C)):
            continue
        name = DEFAULT_FILES[key]
        np.savetxt(folder / name, a, fmt="%.17g", delimiter=",", header=f"{header} ({a.shape[0]} x {a.shape[1]})")
        lines.append(f'{key} = "{name}"')
    (folder / MANIFEST).write_text("\n".join(lines) + "\n", encoding="utf-8")
