"""Sweep files (``scenarios.sweep.spec``): expansion into runs, bad files in one line, the
bundled sweeps."""

from __future__ import annotations

import pytest

from scenarios.loader import ScenarioError, bundled_names
from scenarios.protocol import UserError
from scenarios.sweep import load_sweep, run_sweep
from scenarios.sweep.spec import bundled_sweeps
from tests.worlds import ABSTRACT_SWEEP


def test_expansion_is_every_combination_in_spec_order(abstract_file):
    sw = load_sweep(abstract_file)
    assert len(sw.runs) == 3 * 2 * 5
    assert sw.parameters == ("experience.delta_u",)
    first = sw.runs[0].spec
    assert (first.scenario, first.allocator, first.cost) == ("paper", "ql", "abstract")
    assert first.seed == 0
    assert dict(first.overrides)["stream.n_sets"] == 6
    keys = [sw.key(r) for r in sw.runs]
    assert len(set(keys)) == len(keys)
    assert [k[1] for k in keys[:15]] == ["ql"] * 15 and keys[5][4] == "0.3"


BAD = [
    ("[sweep]\n", "[grd]\n", "grd: unknown key (did you mean 'grid'?)"),
    ("allocators =", "alocators =", "sweep.alocators: unknown key (did you mean 'allocators'?)"),
    (
        '"experience.delta_u" = [',
        '"experience.delta_uu" = [',
        "grid.experience.delta_uu: unknown parameter (did you mean 'experience.delta_u'?)",
    ),
    (
        '"experience.delta_u" = [',
        '"experiance.delta_u" = [',
        "grid.experiance.delta_u: unknown parameter (did you mean 'experience.delta_u'?)",
    ),
    ('"expt"]', '"exptt"]', "sweep.allocators[1]: unknown allocator 'exptt' (did you mean"),
    ("[0.05, 0.3, 0.5]", "[0.05, 5.0]", "grid.experience.delta_u: must be in [0, 2]"),
    ('n_min" = 3', 'n_min" = 2.5', "fixed.experience.n_min: must be an integer"),
    ("seeds = 5", "seeds = 0", "sweep.seeds: need at least one seed"),
    ("seeds = 5", 'seeds = 5\ncosts = ["distance"]', "sweep.costs[0]: cost model 'distance' needs"),
    ('["paper"]', '["papr"]', "did you mean 'paper'?"),
    (
        '"stream.learn_sets" = 4\n',
        "",
        "fixed: makes scenario 'paper' invalid: stream.learn_sets: must be in 1..n_sets (6)",
    ),
    ("[0.05, 0.3, 0.5]", "[0.3, 0.3]", "grid.experience.delta_u: lists a value twice"),
    ("[0.05, 0.3, 0.5]", "[]", "grid.experience.delta_u: must be a non-empty list"),
    (
        '"experience.n_min" = 3\n',
        '"experience.n_min" = 3\n[[points]]\n"learning.history" = 2\n',
        "points: use either [grid] or [[points]], not both",
    ),
    ("seeds = 5", "seeds = 5 5", "TOML syntax error"),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD)
def test_bad_sweep_files_fail_in_one_line(tmp_path, old, new, message):
    assert old in ABSTRACT_SWEEP
    path = tmp_path / "bad.toml"
    path.write_text(ABSTRACT_SWEEP.replace(old, new, 1))
    with pytest.raises((ScenarioError, UserError)) as info:
        run_sweep(path, tmp_path / "out", workers=1, progress=False)
    text = str(info.value)
    assert message in text
    assert text.startswith(str(path)) and "\n" not in text
    assert not (tmp_path / "out").exists()  # nothing was written


@pytest.mark.parametrize("name", bundled_sweeps())
def test_bundled_example_sweeps_validate(name):
    try:
        sw = load_sweep(name)
    except ScenarioError as exc:
        if "paper_spatial" in str(exc) and "paper_spatial" not in bundled_names():
            pytest.skip("paper_spatial scenario not in this checkout yet")
        raise
    assert sw.runs and sw.parameters
