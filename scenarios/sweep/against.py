"""Two runs of one sweep paired by seed: ``against.md`` and ``against.json``.

``mrta sweep SPEC --out NEW --against OLD/runs.csv`` compares, once the sweep is done, every
group of runs (scenario, allocator, cost, swept values) with the same group of an earlier
``runs.csv``, typically the same sweep at another commit (a change of the law) or on another
machine, on the seeds both have: per metric the old and new means and the mean of the
per-seed differences (new less old) with its standard error, also in % of the old mean. The
same seed is the same task stream, so the pairing takes the streams' spread out of the
difference. Groups and seeds on one side only are left out and counted. Nothing is run for
the old file; it is read as it is (the new folder's own ``runs.csv`` is read the same way).
"""

from __future__ import annotations

import csv
import math
import statistics
from pathlib import Path

from scenarios.experiments.output import write_json_atomic
from scenarios.experiments.protocol import UserError
from scenarios.sweep.columns import MOTION_METRICS

METRICS = ("completion_all", *MOTION_METRICS)
TABLE = (  # (metric, column title, digits) of the markdown table, where the runs have it
    ("completion_all", "completion (test sets)", 4),
    ("tasks_allocated", "tasks allocated", 1),
    ("time_to_start_s", "time to arrival s", 2),
)


def read_runs(path: Path, keys: list[str], what: str) -> dict[tuple, dict[int, dict]]:
    """``runs.csv`` at ``path`` as {group key (strings of ``keys`` but the seed): {seed:
    {metric: float or None}}}; one clear line (``UserError``) for a missing or foreign file."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{what}: {path}: no such file")
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        header = reader.fieldnames or []
        missing = [k for k in keys if k not in header]
        if missing:
            raise UserError(
                f"{what}: {path}: not a runs.csv of this sweep (no column {missing[0]!r})"
            )
        group_keys = [k for k in keys if k != "seed"]
        out: dict[tuple, dict[int, dict]] = {}
        for line, row in enumerate(reader, start=2):
            where = f"{what}: {path}, line {line}"
            if not (row["seed"] or "").isdigit():
                raise UserError(f"{where}: seed {row['seed']!r} is not a whole number")
            values = {}
            for m in METRICS:
                text = row.get(m)
                try:
                    values[m] = None if text in (None, "") else float(text)
                except ValueError:
                    raise UserError(f"{where}: {m} {text!r} is not a number") from None
            out.setdefault(tuple(row[k] for k in group_keys), {})[int(row["seed"])] = values
    return out


def paired(old: list[float], new: list[float]) -> dict:
    """Old and new means, the mean per-seed difference (new less old) and its standard error
    (None with one seed), and both in % of the old mean (None when that mean is 0)."""
    diffs = [n - o for o, n in zip(old, new, strict=True)]
    mean_old = statistics.fmean(old)
    diff = statistics.fmean(diffs)
    se = statistics.stdev(diffs) / math.sqrt(len(diffs)) if len(diffs) > 1 else None
    scale = abs(mean_old) if mean_old else None
    return {
        "old": mean_old,
        "new": statistics.fmean(new),
        "diff": diff,
        "diff_se": se,
        "diff_pct": None if scale is None else 100 * diff / scale,
        "diff_pct_se": None if scale is None or se is None else 100 * se / scale,
    }


def compare(old: dict, new: dict, keys: list[str]) -> dict:
    """Every group in both, paired on the seeds both ran (metrics missing on a side skipped);
    and how many groups and seeds were left out."""
    group_keys = [k for k in keys if k != "seed"]
    rows, seeds_left = [], 0
    for key in new:
        if key not in old:
            continue
        seeds = sorted(set(old[key]) & set(new[key]))
        seeds_left += len(set(old[key]) ^ set(new[key]))
        if not seeds:
            continue
        row = dict(zip(group_keys, key, strict=True))
        row["seeds"] = seeds
        for m in METRICS:
            a = [old[key][s][m] for s in seeds]
            b = [new[key][s][m] for s in seeds]
            if None not in a and None not in b:
                row[m] = paired(a, b)
        rows.append(row)
    return {
        "rows": rows,
        "groups_only_old": sum(1 for k in old if k not in new),
        "groups_only_new": sum(1 for k in new if k not in old),
        "seeds_left_out": seeds_left,
    }


def _change(p: dict) -> str:
    if p["diff_pct"] is None:
        return f"{p['diff']:+.4g}"
    se = "" if p["diff_pct_se"] is None else f" ({p['diff_pct_se']:.1f})"
    return f"{p['diff_pct']:+.1f}%{se}"


def _pair_sum(row: dict, a: str, b: str, side: str) -> str:
    return f"{row[a][side] + row[b][side]:.2f}"


def markdown(doc: dict, keys: list[str], old_path, new_path) -> str:
    """The comparison as a markdown table."""
    group_keys = [k for k in keys if k != "seed"]
    rows = doc["rows"]
    shown = [t for t in TABLE if any(t[0] in r for r in rows)]
    spatial = any("contacts_wall_touch_per_robot_h" in r for r in rows)
    head = [*group_keys, "seeds"]
    for _, title, _ in shown:
        head += [f"{title} old / new", "change, % of old (se)"]
    if any("failed_tasks" in r for r in rows):
        head.append("failed old / new")
    if spatial:
        head += ["robot-robot /h old / new", "robot-wall /h old / new"]
    lines = [
        f"`{new_path}` against `{old_path}`, paired by seed: the change is the mean of the "
        "per-seed differences (new less old) in % of the old mean, its standard error in "
        "brackets; contacts are touches and impacts per robot-hour, means over seeds; failed "
        "tasks summed.",
        f"Left out: {doc['groups_only_old']} group(s) only in the old file, "
        f"{doc['groups_only_new']} only in the new, {doc['seeds_left_out']} run(s) whose seed "
        "the other side lacks.",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for r in rows:
        cells = [str(r[k]) for k in group_keys] + [str(len(r["seeds"]))]
        for m, _, digits in shown:
            if m in r:
                cells += [f"{r[m]['old']:.{digits}f} / {r[m]['new']:.{digits}f}", _change(r[m])]
            else:
                cells += ["", ""]
        if "failed old / new" in head:
            n = len(r["seeds"])
            f = r.get("failed_tasks")
            cells.append("" if f is None else f"{f['old'] * n:.0f} / {f['new'] * n:.0f}")
        if spatial:
            robot = ("contacts_robot_touch_per_robot_h", "contacts_robot_impact_per_robot_h")
            wall = ("contacts_wall_touch_per_robot_h", "contacts_wall_impact_per_robot_h")
            for a, b in (robot, wall):
                if a in r and b in r:
                    cells.append(f"{_pair_sum(r, a, b, 'old')} / {_pair_sum(r, a, b, 'new')}")
                else:
                    cells.append("")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_against(old_path: Path, out: Path, keys: list[str]) -> dict:
    """``against.json`` and ``against.md`` in ``out``: ``out/runs.csv`` against ``old_path``."""
    old = read_runs(old_path, keys, "--against")
    new = read_runs(out / "runs.csv", keys, "the sweep's runs.csv")
    doc = compare(old, new, keys)
    write_json_atomic(
        out / "against.json", {"old": str(old_path), "new": str(out / "runs.csv"), **doc}
    )
    tmp = out / ".against.md.tmp"
    tmp.write_text(markdown(doc, keys, old_path, out / "runs.csv") + "\n")
    tmp.replace(out / "against.md")
    return doc
