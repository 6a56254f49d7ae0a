"""Robot faults on the command line: ``soak --faults`` and the run outputs with faults."""

from __future__ import annotations

import pytest

from scenarios.cli import main
from scenarios.loader import resolve


@pytest.mark.parametrize(
    "value, message",
    [
        ("mttf=0", "mttf=0: must be > 0 (s)"),
        ("mttf=-5", "mttf=-5: must be > 0 (s)"),
        ("repair=-1", "repair=-1: must be >= 0 (s)"),
        ("policy=retry", "policy='retry': unknown policy; one of ['requeue', 'drop']"),
        ("mtbf=100", "'mtbf=100': expected KEY=VALUE with KEY one of mttf, repair"),
        ("mttf=abc", "mttf='abc': not a number"),
        ("permanent=2", "permanent=2: probability outside [0, 1]"),
    ],
)
def test_soak_faults_bad_input_is_one_line_and_exit_2(value, message, capsys):
    with pytest.raises(SystemExit) as info:
        main(["soak", "--scenario", "paper_spatial", "--faults", value])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_soak_with_faults_accounts_for_every_task(capsys):
    code = main(["soak", "--scenario", "paper_spatial", "--tasks", "150", "--json",
                 "--faults", "mttf=120,repair=30"])  # fmt: skip
    assert code == 0
    import json

    out = json.loads(capsys.readouterr().out)
    assert out["tasks_unaccounted"] == 0
    assert out["robot_failures"] > 0
    fates = sum(v for k, v in out.items() if k.startswith("fate_"))
    assert fates + out["abandon_requeued"] == out["tasks_announced"]
    assert 0.0 < out["availability_min"] <= out["availability_mean"] < 1.0


def test_run_with_faults_writes_the_fault_figure_and_entries(tmp_path, capsys):
    import json

    sc = tmp_path / "paper_faults.toml"
    text = resolve("paper").read_text().replace("n_sets = 45", "n_sets = 4")
    text = text.replace("learn_sets = 30", "learn_sets = 2").replace(
        "test_sets = 30", "test_sets = 2"
    )
    sc.write_text(text + '\n[faults]\nmttf_s = 150.0\nrepair_s = 30.0\npolicy = "drop"\n')
    assert main(["run", str(sc), "--allocator", "market", "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 0  # fmt: skip
    assert (tmp_path / "o" / "faults.png").is_file()
    m = json.loads((tmp_path / "o" / "metrics.json").read_text())["allocators"]["market"]
    f = m["faults"]
    assert f["policy"] == "drop" and f["abandon_ends"]["requeued"] == 0
    assert f["abandon_ends"]["dropped"] == f["abandoned"] > 0
    assert set(f["availability"]["per_robot"]) == {f"R{j}" for j in range(1, 11)}
    announced = m["tasks"]["announced"]
    assert sum(f["fates"].values()) == announced  # drop: each task announced once
