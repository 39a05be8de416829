import re

import pytest

from caekf_sim import schema
from caekf_sim.scenario import ScenarioError, default_scenario_path, load_scenario, parse_flat, scenario_from_text
from recording_support import text_without, truth_keys_in_use, write_recording, write_scenario_without_truth

PAPER = default_scenario_path()


def test_paper_scenario_values_match_file():
    sc = load_scenario(PAPER)
    raw = parse_flat(PAPER.read_text())
    for key, (_, text) in raw.items():
        assert getattr(sc, key) == float(text), key
    assert isinstance(sc.truth_substeps, int) and sc.truth_substeps == 10
    assert isinstance(sc.seed, int)
    assert sc.n_steps == round(sc.t_end / sc.dt) == 60000


def test_keys_without_value_take_the_schema_default():
    sc = load_scenario(PAPER)
    assert "gamma_gate_nis" not in parse_flat(PAPER.read_text())
    assert sc.gamma_gate_nis == schema.SCHEMA.by_name("gamma_gate_nis").default_value() == 25.0
    assert sc.q0_3 == 0.0 and sc.mode == schema.SCHEMA.by_name("mode").values.index("switched")


def test_comments_and_blank_lines_are_ignored():
    raw = parse_flat("# header\n\na = 1.5   # trailing\n  b=2\n")
    assert raw == {"a": (3, "1.5"), "b": (4, "2")}


def _text_without(key: str) -> str:
    return "\n".join(ln for ln in PAPER.read_text().splitlines() if not ln.startswith(key + " "))


def test_missing_key_is_an_error():
    with pytest.raises(ScenarioError, match="missing key 'contact1_gap'"):
        scenario_from_text(_text_without("gap"))


def test_unknown_key_is_an_error_with_its_line():
    text = PAPER.read_text() + "\ngamma_typo = 3\n"
    line = len(text.splitlines())
    with pytest.raises(ScenarioError, match=f":{line}: unknown key 'gamma_typo'"):
        scenario_from_text(text)


def test_duplicate_key_is_an_error():
    with pytest.raises(ScenarioError, match="duplicate"):
        scenario_from_text(PAPER.read_text() + "\ngap = 2e-3\n")


@pytest.mark.parametrize("key,value,rule", [
    ("m2", "-1", "must be finite and > 0"),
    ("m2", "0", "must be finite and > 0"),
    ("gap", "-1e-3", "must be finite and >= 0"),
    ("k12", "nan", "not a finite number"),
    ("sigma_r", "0", "must be finite and > 0"),
    ("seed", "1.5", "must be an integer"),
    ("truth_substeps", "2.5", "must be an integer"),
    ("mode", "2", "must be one of 0 (canonical), 1 (switched)"),
    ("newton_rtol", "1", "must be in (0, 1)"),
])
def test_values_are_checked_against_the_schema_rule(key, value, rule):
    """One line: file, line, key = value and the rule, as the C reader says it."""
    text = _text_without(key) + f"\n{key} = {value}\n"
    line = len(text.splitlines())
    with pytest.raises(ScenarioError) as err:
        scenario_from_text(text, "f.toml")
    msg = str(err.value)
    assert msg.startswith(f"f.toml:{line}: ") and rule in msg and "\n" not in msg, msg


def test_malformed_line_is_an_error():
    with pytest.raises(ScenarioError, match="key = value"):
        parse_flat("just words\n")


def test_replace_is_checked_too():
    sc = load_scenario(PAPER)
    assert sc.replace(t_end=1.0).n_steps == 1000
    with pytest.raises(ScenarioError, match="t_end"):
        sc.replace(t_end=-1.0)


# ---- a recording's scenario: no truth-only key ---------------------------------------------------------------


def test_a_scenario_without_truth_keys_loads_and_runs_the_binding(tmp_path):
    """The loader takes a scenario with no truth-only key (what a user writes for a real mechanism):
    the keys are missing, not invented, and caekf_sim.run estimates from it exactly as from the full file."""
    import numpy as np

    import caekf_sim

    path = write_scenario_without_truth(tmp_path / "mechanism.toml")
    sc = load_scenario(path)
    assert not sc.has_truth and sc.missing_truth() == truth_keys_in_use()
    assert not set(truth_keys_in_use()) & set(sc.values())  # left out, as the file leaves them (written back so)
    assert sc.replace(sigma_r=2e-7).missing_truth() == truth_keys_in_use()
    rec = np.loadtxt(write_recording(tmp_path / "rec.csv"), delimiter=",", skiprows=1)
    got = caekf_sim.run(path, rec[:, 1], rec[:, 2:])
    want = caekf_sim.run(PAPER, rec[:, 1], rec[:, 2:])
    assert np.array_equal(got.x, want.x) and np.array_equal(got.flags, want.flags)


@pytest.mark.parametrize("key", truth_keys_in_use())
def test_simulating_a_truth_refuses_a_missing_truth_key_naming_file_and_key(key, tmp_path):
    from caekf_sim.binding import truth as c_truth
    from caekf_sim.truth import simulate

    path = tmp_path / "no-truth.toml"
    path.write_text(text_without([key]))
    sc = load_scenario(path)
    assert sc.missing_truth() == [key]
    message = f"^{re.escape(str(path))}: missing key '{key}' \\(it has no default; simulating a truth needs it\\)$"
    for fn in (simulate, c_truth):
        with pytest.raises(ScenarioError, match=message):
            fn(sc)
