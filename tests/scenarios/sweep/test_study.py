"""``mrta study refusal``: small versions of its sweeps, read back from the written outputs."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from scenarios.sweep.spec import load_sweep
from scenarios.sweep.study import run_study
from scenarios.sweep.study_analysis import analyse, series_key

SHORT = """
[fixed]
"stream.n_sets" = 6
"stream.rounds_per_set" = 8
"stream.learn_sets" = 4
"stream.test_sets" = 3
"""


def strict_json(path):
    """Parse JSON refusing NaN and Infinity tokens (what JavaScript's JSON.parse does)."""

    def refuse(token):
        raise AssertionError(f"{path}: non-standard JSON token {token}")

    return json.loads(path.read_text(), parse_constant=refuse)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    root = tmp_path_factory.mktemp("study")
    (root / "refusal_load.toml").write_text(
        '[sweep]\nscenarios = ["paper"]\nallocators = ["market", "ql", "expt"]\nseeds = 2\n'
        + SHORT
        + "".join(
            f'\n[[points]]\n"stream.batch_min" = {a}\n"stream.batch_max" = {b}\n'
            f'"stream.announce_interval_s" = {iv}\n"experience.refusal" = "{rule}"\n'
            + ('allocators = ["expt"]\n' if rule == "reserve" else "")
            for a, b, iv in ((1, 2, 10.0), (3, 7, 10.0), (3, 7, 30.0))
            for rule in ("paper", "reserve")
        )
    )
    (root / "refusal_frontier.toml").write_text(
        '[sweep]\nscenarios = ["paper"]\nallocators = ["expt"]\nseeds = 2\n'
        + SHORT.replace('"stream.n_sets" = 6', '"stream.n_sets" = 6\n"experience.n_min" = 5')
        + '\n[grid]\n"experience.refusal" = ["paper", "reserve"]\n'
        '"experience.delta_u" = [0.1, 0.6]\n"experience.coverage_k" = [1]\n'
    )
    parts = (str(root / "refusal_load.toml"), str(root / "refusal_frontier.toml"))
    out = root / "out"
    doc = run_study(out, parts, workers=1, progress=False)
    return root, out, doc


@pytest.mark.slow
def test_points_may_name_their_allocators(study):
    root, _, _ = study
    sweep = load_sweep(root / "refusal_load.toml")
    runs = [(r.spec.allocator, dict(r.spec.overrides)["experience.refusal"]) for r in sweep.runs]
    assert ("market", "reserve") not in runs and ("ql", "reserve") not in runs
    assert runs.count(("expt", "reserve")) == 3 * 2  # three loads, two seeds
    assert len(runs) == 3 * 2 * (3 + 1)


@pytest.mark.slow
def test_study_writes_strict_json_tables_and_figures(study):
    _, out, doc = study
    assert strict_json(out / "study.json") == json.loads(json.dumps(doc))
    for name in ("study.md", "load.png", "losses.png", "frontier.png"):
        assert (out / name).stat().st_size > 0
    assert (out / "refusal_load" / "runs.csv").is_file()


@pytest.mark.slow
def test_offered_load_and_loss_shares_come_from_the_runs(study):
    _, out, doc = study
    loads = {(e["offered_load"], e["all_free"]) for e in doc["load"]}
    # 1.5 x 30 s / (10 s x 10) = 0.45; 5 x 30 / (10 x 10) = 1.5; 5 x 30 / (30 x 10) = 0.5
    assert loads == {(0.45, False), (1.5, False), (0.5, True)}
    with (out / "refusal_load" / "runs.csv").open() as fh:
        runs = list(csv.DictReader(fh))
    for e in doc["load"]:
        mine = [
            r
            for r in runs
            if float(r["offered_load"]) == e["offered_load"]
            and float(r["stream.announce_interval_s"]) == e["announce_interval_s"]
            and series_key(r) == e["series"]
        ]
        assert len(mine) == e["seeds"] == 2
        announced = np.mean([int(r["tasks_announced"]) for r in mine])
        lost = np.mean([int(r["tasks_announced"]) - int(r["tasks_allocated"]) for r in mine])
        assert sum(e["lost_share"].values()) == pytest.approx(lost / announced)
        assert e["all"]["mean"] == pytest.approx(
            np.mean([float(r["completion_all"]) for r in mine])
        )


@pytest.mark.slow
def test_market_and_ql_lose_nothing_to_refusal(study):
    _, _, doc = study
    for e in doc["load"]:
        if e["series"] in ("market", "ql"):
            assert e["lost_share"]["refused"] == 0
        if e["series"] == "market":
            assert e["lost_share"]["waited"] == 0


@pytest.mark.slow
def test_gaps_and_goal_are_computed_from_the_table(study):
    _, _, doc = study
    by = {(e["offered_load"], e["all_free"], e["series"]): e for e in doc["load"]}
    for (load, free, key), e in by.items():
        if key.startswith("expt"):
            ql = by[(load, free, "ql")]
            assert e["gap_to_ql"]["all"] == pytest.approx(e["all"]["mean"] - ql["all"]["mean"])
    for rule in ("paper", "reserve"):
        g = doc["goal"][rule]
        gaps = [e["gap_to_ql"]["all"] for e in doc["load"] if e["series"] == f"expt/{rule}"]
        assert g["worst_gap_all"] == min(gaps)
        assert g["met"] == (
            g["worst_gap_all"] >= -0.02 and g["worst_gap_high"] >= -0.02
            and g["space_at_paper_load"] <= 700
        )  # fmt: skip


@pytest.mark.slow
def test_frontier_marks_pareto_points(study):
    _, _, doc = study
    for rule in ("paper", "reserve"):
        mine = [e for e in doc["frontier"] if e["rule"] == rule]
        assert len(mine) == 2
        for e in mine:
            dominated = any(
                o["space_final"]["mean"] <= e["space_final"]["mean"]
                and o["all"]["mean"] >= e["all"]["mean"]
                and o is not e
                and (o["space_final"]["mean"], o["all"]["mean"])
                != (e["space_final"]["mean"], e["all"]["mean"])
                for o in mine
            )
            if dominated:
                assert not e["on_frontier"]


def test_analyse_never_emits_nan_or_infinity():
    rows = {
        "refusal_frontier": [
            {"experience.refusal": "paper", "experience.delta_u": 0.1,
             "experience.coverage_k": 2, "space_final": v, "completion_all": 0.5,
             "completion_high": None, "completion_low": 0.4}
            for v in (100, 200)
        ]
    }  # fmt: skip
    doc = analyse(rows)
    text = json.dumps(doc, allow_nan=False)  # raises on NaN or infinity
    assert math.isfinite(json.loads(text)["frontier"][0]["space_final"]["mean"])
    assert json.loads(text)["frontier"][0]["high"]["mean"] is None
