"""Scenario validation on the command line and the CLI's error contract: one line, exit code 2,
no traceback (``mrta validate`` of bad files, bad arguments, unknown names)."""

from __future__ import annotations

import pytest

from scenarios.cli import main
from scenarios.loader import (
    bundled_names,
    locate,
)
from tests.worlds import variant


def run_cli(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


BAD = [
    ("p_high = 0.35", "p_hihg = 0.35", "stream.p_hihg: unknown key (did you mean 'p_high'?)"),
    ("p_high = 0.35", "p_high = 1.35", "stream.p_high: must be in [0, 1], got 1.35"),
    ("p_high = 0.35", "p_high = -0.1", "stream.p_high: must be in [0, 1], got -0.1"),
    ("n_sets = 45", 'n_sets = "45"', "stream.n_sets: must be a number, got string '45'"),
    ("n_sets = 45", "n_sets = -3", "stream.n_sets: must be in [1, 100,000], got -3"),
    ("alpha = 0.1", "alpha = nan", "learning.alpha: must be finite"),
    (
        'capabilities = ["T4", "T8"]',
        "capabilities = []",
        "robots[3].capabilities: needs 1 to 8 entries",
    ),
    ('name = "R4"', 'name = "R3"', "robots[3].name: duplicate robot name 'R3'"),
    (
        "cost = { T4 = 3, T8 = 9 }",
        "cost = { T4 = 3 }",
        "robots[3].cost: missing cost for capability 'T8'",
    ),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD)
def test_bad_scenarios_one_line_exit_2(tmp_path, capsys, old, new, message):
    path = variant(tmp_path, old, new)
    code, out, err = run_cli(capsys, "validate", str(path))
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"mrta: error: {path}: ")
    assert message in err


def test_syntax_error(tmp_path, capsys):
    path = tmp_path / "broken.toml"
    path.write_text("[scenario\nname = 1\n")
    code, _, err = run_cli(capsys, "validate", str(path))
    assert code == 2 and "TOML syntax error" in err and err.count("\n") == 1


def test_missing_file(capsys, tmp_path):
    code, _, err = run_cli(capsys, "validate", str(tmp_path / "nope.toml"))
    assert code == 2 and "nope.toml: file not found" in err


def test_validate_checks_sweep_files_by_name_and_by_path(capsys):
    """10 seeds x 3 scenarios x 3 allocators x 1 cost x 2 avoidance settings; by path the
    same file as the bundled name, and a scenario beside it still reads as a scenario."""
    code, out, _ = run_cli(capsys, "validate", "avoidance_layouts")
    assert code == 0
    assert out.endswith(": ok: sweep 'avoidance_layouts', 180 runs (18 combinations x 10 seeds)\n")
    path = locate("avoidance", "sweeps")
    code, out, _ = run_cli(capsys, "validate", str(path), "warehouse")
    first, second = out.splitlines()
    assert code == 0
    assert first == f"{path}: ok: sweep 'avoidance', 60 runs (12 combinations x 5 seeds)"
    described = "ok: 'warehouse', 10 robots, 4 task types, 30 sets x 18 rounds, spatial"
    assert second.endswith(f": {described}")


def test_validate_names_a_bad_sweep_file_s_problem_in_one_line(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text('[sweep]\nscenarios = ["warehouse"]\nallocators = ["markt"]\nseeds = 2\n')
    code, out, err = run_cli(capsys, "validate", str(path))
    assert code == 2 and out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"mrta: error: {path}: sweep.allocators[0]: unknown allocator 'markt'")


def test_unknown_bundled_name(capsys):
    code, _, err = run_cli(capsys, "reproduce", "--scenario", "papr")
    assert code == 2 and "did you mean 'paper'?" in err


def test_bad_arguments_exit_2(capsys):
    with pytest.raises(SystemExit) as info:
        main(["reproduce", "--seeds", "-4"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "mrta: error:" in err and "(see 'mrta reproduce --help')" in err
    assert err.count("\n") == 1


def test_unknown_argument_points_at_the_help_that_exists(capsys):
    """argparse reports arguments no command knows from the top parser: the hint must not
    read 'mrta mrta --help'."""
    with pytest.raises(SystemExit) as info:
        main(["run", "paper", "--sets", "0"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "unrecognized arguments: --sets 0" in err and "(see 'mrta --help')" in err
    assert "mrta mrta" not in err and err.count("\n") == 1


def test_distance_cost_needs_spatial_scenario(capsys):
    code, _, err = run_cli(capsys, "run", "paper", "--cost", "distance")
    assert code == 2 and "needs a spatial scenario" in err


@pytest.mark.parametrize("name", bundled_names())
def test_every_bundled_scenario_validates(capsys, name):
    code, out, _ = run_cli(capsys, "validate", name)
    assert code == 0 and ": ok: " in out


def test_a_folder_named_like_a_bundled_scenario_does_not_shadow_it(tmp_path, monkeypatch):
    """After `mrta reproduce --out paper` a folder `paper` exists; `paper` still means the
    bundled scenario, while an existing TOML file of that name would be taken as given."""
    from scenarios.loader import load_scenario

    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper").mkdir()
    assert load_scenario("paper").name == "paper"
    assert main(["validate", "paper"]) == 0


def test_version_names_the_package_version(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"mrta (expt-mrta) {version('expt-mrta')}"


def test_debug_adds_the_traceback_to_the_one_line(capsys, tmp_path):
    missing = tmp_path / "missing.toml"
    assert main(["validate", str(missing)]) == 2
    quiet = capsys.readouterr().err
    assert quiet.strip().splitlines() == [f"mrta: error: {missing}: file not found"]
    assert main(["--debug", "validate", str(missing)]) == 2
    loud = capsys.readouterr().err
    assert "Traceback (most recent call last)" in loud and "ScenarioError" in loud
    assert loud.strip().splitlines()[-1] == f"mrta: error: {missing}: file not found"
