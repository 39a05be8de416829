"""The structure folder format (caekf_sim.structure.files): exact round trip, one test per validation rule
with its message, and the modal form."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np
import pytest
import scipy.linalg

from caekf_sim.structure.files import MANIFEST, Structure, StructureError, load_structure, write_structure


def chain(n: int = 6) -> Structure:
    """A spring chain with a consistent (non-diagonal) mass, Rayleigh damping, two inputs, contacts, sensors;
    entries with many digits so that a lossy writer would show."""
    rng = np.random.default_rng(7)
    k = 1e4 * (1 + rng.random(n))
    K = np.diag(k + np.roll(k, -1)) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    K[-1, -1] = k[-1]
    m = 0.1 * (1 + rng.random(n))
    M = np.diag(m) + 0.01 * (np.diag(m[1:], 1) + np.diag(m[1:], -1))
    W = np.zeros((n, 2))
    W[-1, 0], W[2, 1] = 1.0, -1.0
    H = rng.standard_normal((3, n))
    return Structure(M=M, K=K, C=0.3 * M + 1e-4 * K, Bu=rng.standard_normal((n, 2)), W=W, H=H)


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    write_structure(tmp_path / "s", chain(), comment="a test chain\nsecond line")
    return tmp_path / "s"


def test_round_trip_is_exact(folder: Path) -> None:
    s, back = chain(), load_structure(folder)
    for a, b in zip(s.matrices().values(), back.matrices().values()):
        assert a.shape == b.shape and np.array_equal(a, b)
    assert (back.dofs, back.inputs, back.contacts, back.sensors) == (6, 2, 2, 3)
    text = (folder / MANIFEST).read_text()
    assert text.startswith("# a test chain\n# second line\n") and 'contacts = "W.csv"' in text


def test_round_trip_without_inputs_or_damping(tmp_path: Path) -> None:
    s = chain()
    bare = Structure(M=s.M, K=s.K, C=np.zeros_like(s.M), Bu=np.zeros((6, 0)), W=s.W, H=s.H)
    write_structure(tmp_path, bare)
    assert not (tmp_path / "Bu.csv").exists() and not (tmp_path / "C.csv").exists()
    back = load_structure(tmp_path)
    assert back.inputs == 0 and not np.any(back.C) and np.array_equal(back.K, s.K)


def test_rayleigh_key_gives_alpha_m_plus_beta_k(folder: Path) -> None:
    text = (folder / MANIFEST).read_text().replace('damping = "C.csv"', "rayleigh = [0.5, 2e-4]")
    (folder / MANIFEST).write_text(text)
    s = load_structure(folder)
    np.testing.assert_array_equal(s.C, 0.5 * s.M + 2e-4 * s.K)


def test_reads_what_numpy_savetxt_and_comments_write(tmp_path: Path) -> None:
    """An FE user's export: savetxt's default format, a comment and a blank line, a column vector for W."""
    s = chain()
    for name, a in (("M.csv", s.M), ("K.csv", s.K), ("W.csv", s.W[:, 0]), ("H.csv", s.H)):
        np.savetxt(tmp_path / name, a, delimiter=",", header="exported")
    with open(tmp_path / "K.csv", "a") as f:
        f.write("\n# trailing comment\n")
    (tmp_path / MANIFEST).write_text('mass = "M.csv"\nstiffness = "K.csv"\ncontacts = "W.csv"\nsensors = "H.csv"\n')
    back = load_structure(tmp_path)
    assert back.W.shape == (6, 1) and back.inputs == 0
    np.testing.assert_allclose(back.K, s.K, rtol=1e-15)


def set_manifest(old: str, new: str) -> Callable[[Path], None]:
    def edit(folder: Path) -> None:
        text = (folder / MANIFEST).read_text()
        assert old in text
        (folder / MANIFEST).write_text(text.replace(old, new))
    return edit


def set_entry(name: str, i: int, j: int, value: str) -> Callable[[Path], None]:
    """Entry (i, j), 0-based, of the CSV `name` replaced by the text `value`."""
    def edit(folder: Path) -> None:
        path = folder / name
        lines = path.read_text().splitlines()
        rows = [k for k, line in enumerate(lines) if not line.startswith("#")]
        fields = lines[rows[i]].split(",")
        fields[j] = value
        lines[rows[i]] = ",".join(fields)
        path.write_text("\n".join(lines) + "\n")
    return edit


def save(name: str, make: Callable[[Structure], np.ndarray]) -> Callable[[Path], None]:
    def edit(folder: Path) -> None:
        np.savetxt(folder / name, make(chain()), delimiter=",", fmt="%.17g")
    return edit


def drop_line(name: str) -> Callable[[Path], None]:
    def edit(folder: Path) -> None:
        lines = (folder / name).read_text().splitlines()
        (folder / name).write_text("\n".join(lines[:3] + [lines[3] + ",1.0"] + lines[4:]) + "\n")
    return edit


def not_pd(s: Structure) -> np.ndarray:
    M = s.M.copy()
    M[3, 3] = -1.0
    return M


def zero_column(s: Structure) -> np.ndarray:
    W = s.W.copy()
    W[:, 1] = 0.0
    return W


def asymmetric(s: Structure) -> np.ndarray:
    K = s.K.copy()
    K[2, 4] = 1.2e4
    K[4, 2] = 1.1e4
    return K


RULES = [
    (set_manifest('stiffness =', 'stifness ='), "structure.toml: unknown key 'stifness'"),
    (set_manifest('sensors = "H.csv"', ''), "structure.toml: missing key 'sensors'"),
    (set_manifest('"K.csv"', '3'), "structure.toml: 'stiffness' must be a file name (a string)"),
    (set_manifest('mass =', 'rayleigh = [1, 2]\nmass ='),
     "structure.toml: 'damping' and 'rayleigh' both given: use one"),
    (set_manifest('damping = "C.csv"', 'rayleigh = [1, "x"]'),
     "structure.toml: 'rayleigh' must be [alpha, beta], two finite numbers"),
    (set_manifest('mass =', 'mass = = '), "structure.toml: "),
    (set_manifest('"H.csv"', '"h.csv"'), "h.csv: file not found (structure.toml key 'sensors')"),
    (set_entry("K.csv", 3, 2, "1.2x4"), "K.csv: line 5: cannot read '1.2x4' as a number"),
    (drop_line("K.csv"), "K.csv: line 4 has 7 numbers, line 2 has 6"),
    (lambda f: (f / "W.csv").write_text("# nothing\n"), "W.csv: no numbers"),
    (set_entry("H.csv", 1, 0, "nan"), "H.csv: entry (2, 1) = nan: must be finite"),
    (save("M.csv", lambda s: s.M[:5]), "M.csv: 5 x 6: must be square"),
    (save("K.csv", lambda s: s.K[:5, :5]), "K.csv: 5 x 5, but M.csv is 6 x 6"),
    (save("W.csv", lambda s: np.vstack([s.W, s.W[:1]])), "W.csv: 7 rows, but M.csv has 6"),
    (save("H.csv", lambda s: s.H[:, :5]), "H.csv: 5 columns, but M.csv has 6 rows"),
    (save("K.csv", asymmetric), "K.csv: entry (3, 5) = 12000.0 but (5, 3) = 11000.0: must be symmetric"),
    (save("M.csv", not_pd), "M.csv: not positive definite (Cholesky fails at row 4)"),
    (save("W.csv", zero_column), "W.csv: column 2 is zero"),
    (set_manifest('"C.csv"', '"K.csv"\ninputs = "Bu.csv"'), "structure.toml: "),  # TOML: inputs twice
]


@pytest.mark.parametrize("edit,message", RULES, ids=[m for _, m in RULES])
def test_each_rule_names_file_and_entry(folder: Path, edit: Callable[[Path], None], message: str) -> None:
    edit(folder)
    with pytest.raises(StructureError) as err:
        load_structure(folder)
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def test_symmetry_tolerance_passes_rounding_not_more(folder: Path) -> None:
    s = chain()
    for scale, ok in ((0.5e-9, True), (2e-9, False)):
        K = s.K.copy()
        K[2, 4] += scale * np.max(np.abs(s.K))
        np.savetxt(folder / "K.csv", K, delimiter=",", fmt="%.17g")
        if ok:
            load_structure(folder)
        else:
            with pytest.raises(StructureError, match="must be symmetric"):
                load_structure(folder)


def test_missing_manifest_and_writer_refusals(tmp_path: Path) -> None:
    with pytest.raises(StructureError, match=r"^structure.toml: not found in "):
        load_structure(tmp_path)
    s = chain()
    with pytest.raises(StructureError, match=r"^structure.toml: a structure needs at least one contact"):
        write_structure(tmp_path, Structure(M=s.M, K=s.K, C=s.C, Bu=s.Bu, W=np.zeros((6, 0)), H=s.H))
    with pytest.raises(StructureError, match=r"^C.csv: entry \(1, 2\)"):
        write_structure(tmp_path, Structure(M=s.M, K=s.K, C=np.triu(s.C), Bu=s.Bu, W=s.W, H=s.H))
    with pytest.raises(StructureError, match=r"^W.csv: 5 rows, but M.csv has 6"):
        Structure(M=s.M, K=s.K, C=s.C, Bu=s.Bu, W=s.W[:5], H=s.H)


def test_structure_is_read_only() -> None:
    s = chain()
    with pytest.raises(ValueError):
        s.K[0, 0] = 1.0


def test_modal_form_is_exact() -> None:
    s = chain()
    modal, phi = s.modal()
    assert not s.diagonal_mass() and modal.diagonal_mass()
    np.testing.assert_array_equal(modal.M, np.eye(6))
    np.testing.assert_allclose(phi.T @ s.M @ phi, np.eye(6), atol=1e-12)
    omega2 = scipy.linalg.eigh(s.K, s.M, eigvals_only=True)
    np.testing.assert_allclose(np.diag(modal.K), omega2, rtol=1e-12)
    np.testing.assert_allclose(scipy.linalg.eigh(modal.K, modal.M, eigvals_only=True), omega2, rtol=1e-12)
    # the same physics: q = phi eta, so the projected input, contact and sensor act on the same motion
    np.testing.assert_allclose(s.M @ phi @ modal.W, s.W, atol=1e-12)  # phi^-T = M phi
    np.testing.assert_allclose(modal.H, s.H @ phi, rtol=1e-15)
    # static compliance of the contacts unchanged: W^T K^-1 W
    np.testing.assert_allclose(modal.W.T @ np.linalg.solve(modal.K, modal.W), s.W.T @ np.linalg.solve(s.K, s.W),
                               rtol=1e-10)
    np.testing.assert_allclose(modal.C, phi.T @ s.C @ phi, rtol=1e-12, atol=1e-12)
    assert np.array_equal(modal.C, modal.C.T)
