from pathlib import Path

import pytest

from caekf_sim.scenario import default_scenario_path, load_scenario, parse_flat, scenario_from_text

PAPER = default_scenario_path()


def test_paper_scenario_values_match_file():
    sc = load_scenario(PAPER)
    raw = parse_flat(PAPER.read_text())
    for key, text in raw.items():
        assert getattr(sc, key) == float(text), key
    assert isinstance(sc.truth_substeps, int) and sc.truth_substeps == 10
    assert isinstance(sc.seed, int)
    assert sc.n_steps == round(sc.t_end / sc.dt) == 60000


def test_comments_and_blank_lines_are_ignored():
    raw = parse_flat("# header\n\na = 1.5   # trailing\n  b=2\n")
    assert raw == {"a": "1.5", "b": "2"}


def _text_without(key: str) -> str:
    return "\n".join(l for l in PAPER.read_text().splitlines() if not l.startswith(key + " "))


def test_missing_key_is_an_error():
    with pytest.raises(ValueError, match="missing.*gap"):
        scenario_from_text(_text_without("gap"))


def test_unknown_key_is_an_error():
    with pytest.raises(ValueError, match="unknown.*gamma_typo"):
        scenario_from_text(PAPER.read_text() + "\ngamma_typo = 3\n")


def test_duplicate_key_is_an_error():
    with pytest.raises(ValueError, match="duplicate"):
        scenario_from_text(PAPER.read_text() + "\ngap = 2e-3\n")


def test_malformed_line_and_non_integer_substeps_are_errors():
    with pytest.raises(ValueError, match="key = value"):
        parse_flat("just words\n")
    with pytest.raises(ValueError, match="integer"):
        scenario_from_text(_text_without("truth_substeps") + "\ntruth_substeps = 2.5\n")


def test_shared_copy_is_identical_when_present():
    shared = Path(__file__).resolve().parents[3] / "shared" / "scenarios" / "paper.toml"
    if not shared.exists():
        pytest.skip("shared/ not beside the repository")
    assert load_scenario(shared) == load_scenario(PAPER)
