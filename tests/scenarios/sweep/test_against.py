"""`mrta sweep --against OLD/runs.csv`: two runs of a sweep paired by seed (against.md/json)."""

from __future__ import annotations

import csv
import math

import pytest

from scenarios.protocol import UserError
from scenarios.sweep.against import compare, markdown, read_runs

KEYS = ["scenario", "allocator", "cost", "seed", "spatial.avoidance"]


HEADER = [*KEYS, "completion_all", "tasks_allocated", "time_to_start_s", "failed_tasks"]


def write(path, rows):
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(HEADER)
        w.writerows(rows)
    return path


def test_groups_are_paired_on_the_seeds_both_have(tmp_path):
    old = write(
        tmp_path / "old.csv",
        [
            ["warehouse", "market", "abstract", 0, "orca", 0.6, 100, 10.0, 0],
            ["warehouse", "market", "abstract", 1, "orca", 0.5, 110, 12.0, 1],
            ["warehouse", "market", "abstract", 2, "orca", 0.4, 90, 11.0, 0],
            ["warehouse", "ql", "abstract", 0, "orca", 0.5, 100, 10.0, 0],  # only here
        ],
    )
    new = write(
        tmp_path / "new.csv",
        [
            ["warehouse", "market", "abstract", 0, "orca", 0.6, 104, 9.0, 0],
            ["warehouse", "market", "abstract", 1, "orca", 0.5, 110, 12.0, 0],
            ["warehouse", "market", "abstract", 3, "orca", 0.5, 500, 99.0, 9],  # seed 3: new only
            ["warehouse", "expt", "abstract", 0, "orca", 0.5, 100, 10.0, 0],  # only here
        ],
    )
    doc = compare(read_runs(old, KEYS, "old"), read_runs(new, KEYS, "new"), KEYS)
    (row,) = doc["rows"]
    assert (row["allocator"], row["spatial.avoidance"], row["seeds"]) == ("market", "orca", [0, 1])
    t = row["tasks_allocated"]
    assert (t["old"], t["new"], t["diff"]) == (105.0, 107.0, 2.0)  # per-seed +4, 0
    assert t["diff_se"] == pytest.approx(2.0)  # stdev(4, 0) / sqrt(2)
    assert t["diff_pct"] == pytest.approx(200 / 105)
    assert row["time_to_start_s"]["diff"] == -0.5
    assert row["failed_tasks"]["old"] == 0.5 and row["failed_tasks"]["new"] == 0.0
    assert "contacts_wall_touch_per_robot_h" not in row  # not in these files: skipped
    assert (doc["groups_only_old"], doc["groups_only_new"], doc["seeds_left_out"]) == (1, 1, 2)
    text = markdown(doc, KEYS, old, new)
    line = next(x for x in text.splitlines() if "| market |" in x)
    assert "| 105.0 / 107.0 | +1.9% (1.9) |" in line and "| 1 / 0 |" in line
    assert "Left out: 1 group(s) only in the old file, 1 only in the new, 2 run(s)" in text


def test_a_single_seed_has_no_standard_error(tmp_path):
    rows = [["paper", "ql", "abstract", 0, "none", 0.5, 100, "", 0]]
    one = write(tmp_path / "one.csv", rows)
    doc = compare(read_runs(one, KEYS, "a"), read_runs(one, KEYS, "b"), KEYS)
    (row,) = doc["rows"]
    assert row["completion_all"]["diff"] == 0.0 and row["completion_all"]["diff_se"] is None
    assert "time_to_start_s" not in row  # empty cells: an abstract run
    assert not math.isnan(row["tasks_allocated"]["diff_pct"])


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "--against: {p}: no such file"),
        (
            "scenario,allocator,seed\n",
            "--against: {p}: not a runs.csv of this sweep (no column 'cost')",
        ),
        (
            ",".join(HEADER) + "\nw,m,a,zero,orca,1,1,1,0\n",
            "--against: {p}, line 2: seed 'zero' is not a whole number",
        ),
        (
            ",".join(HEADER) + "\nw,m,a,0,orca,1,many,1,0\n",
            "--against: {p}, line 2: tasks_allocated 'many' is not a number",
        ),
    ],
)
def test_a_bad_old_file_is_one_clear_line(tmp_path, content, message):
    p = tmp_path / "old.csv"
    if content is not None:
        p.write_text(content)
    with pytest.raises(UserError) as err:
        read_runs(p, KEYS, "--against")
    assert str(err.value).startswith(message.format(p=p))
