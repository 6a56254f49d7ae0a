"""Per-run summaries and their aggregation over seeds (means, 95% confidence intervals).

The summary of one run is a plain JSON-able dict; ``aggregate`` turns a list of them (one per
seed) into the ``metrics.json`` entry of an allocator (schema in the README).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import stats

from learning.episode import LOSS_CAUSES, PhaseRecord, RunRecord
from learning.fates import ABANDON_ENDS, FATES
from learning.qlmrta import joint_log10
from sim.scenario import Scenario
from sim.tasks import TaskStream

PRIORITIES = ("low", "high")


def _ratio(allocated: int, announced: int) -> float:
    return allocated / announced if announced else float("nan")


def offered_load(scenario: Scenario) -> float:
    """Work offered per unit of fleet capacity: mean batch x mean execution time / (interval x m).

    Travel is not counted (it depends on the allocation): in a spatial world the real load is
    higher. Above 1 the fleet cannot do every task even if every robot is always busy.
    """
    s = scenario.stream
    mean_batch = (s.batch_min + s.batch_max) / 2.0
    mean_exec = float(np.mean(scenario.exec_time_s))
    return mean_batch * mean_exec / (s.announce_interval_s * scenario.n_robots)


def specialisation(scenario: Scenario, types: np.ndarray, robots: np.ndarray) -> dict:
    """Entropy (bits) of the task types each robot did: 0 = one type only.

    Args:
        types, robots: type and robot of every task allocated (test phase).
    """
    per_robot = {}
    for j, robot in enumerate(scenario.robots):
        counts = np.bincount(types[robots == j], minlength=scenario.n_types).astype(float)
        total = counts.sum()
        if total == 0:
            per_robot[robot.name] = None
            continue
        p = counts[counts > 0] / total
        per_robot[robot.name] = float(-(p * np.log2(p)).sum()) + 0.0
    done = [h for h in per_robot.values() if h is not None]
    return {
        "entropy_bits_mean": float(np.mean(done)) if done else None,
        "entropy_bits": per_robot,
        "note": "entropy of the task types each robot was allocated on the test sets; "
        "null for a robot allocated nothing",
    }


def summarize_run(scenario: Scenario, stream: TaskStream, record: RunRecord, learns: bool) -> dict:
    """JSON-able summary of one run: test-phase completion, tasks, learning space, experience,
    why tasks were lost, offered load and specialisation.

    With robot faults (a ``[faults]`` table that lets a robot break) a task may be announced
    more than once: completion then counts each task once, as taken if its last allocation was
    not abandoned (fates done, failed, abandoned_done, abandoned_failed; without faults this is
    the share allocated, as before), and a ``faults`` entry says what the faults did."""
    ids, assigned = record.test.arrays()
    if scenario.has_faults:
        ids, assigned = final_allocation(ids, assigned, record.test)
    high = stream.high[ids]
    types = stream.types[ids]
    taken = assigned >= 0
    by_type = {}
    for i, name in enumerate(scenario.task_types):
        sel = types == i
        by_type[name] = {
            "low": _ratio(int((taken & sel & ~high).sum()), int((sel & ~high).sum())),
            "high": _ratio(int((taken & sel & high).sum()), int((sel & high).sum())),
        }
    out: dict[str, Any] = {
        "completion": {
            "overall": {
                "low": _ratio(int((taken & ~high).sum()), int((~high).sum())),
                "high": _ratio(int((taken & high).sum()), int(high.sum())),
                "all": _ratio(int(taken.sum()), int(taken.size)),
            },
            "by_type": by_type,
        },
        "tasks": {"announced": int(taken.size), "allocated": int(taken.sum())},
        "lost": dict(zip(LOSS_CAUSES, record.test.lost_causes.tolist(), strict=True)),
        "offered_load": offered_load(scenario),
        "willing_per_type": dict(
            zip(scenario.task_types, record.willing_final.sum(axis=0).tolist(), strict=True)
        ),
        "specialisation": specialisation(scenario, types[taken], assigned[taken]),
    }
    if scenario.has_faults:
        out["faults"] = fault_summary(scenario, record)
    if learns:
        names = [r.name for r in scenario.robots]
        out["learning_space"] = {
            "initial": int(record.space_initial.sum()),
            "final": int(record.space_final.sum()),
            "joint_log10": joint_log10(record.space_final),
            "joint_log10_initial": joint_log10(record.space_initial),
            "per_robot_initial": dict(zip(names, record.space_initial.tolist(), strict=True)),
            "per_robot_final": dict(zip(names, record.space_final.tolist(), strict=True)),
        }
        out["capabilities"] = {
            r.name: [scenario.task_types[i] for i in r.capabilities] for r in scenario.robots
        }
        out["experienced_tasks"] = {
            name: [scenario.task_types[i] for i in np.flatnonzero(row)]
            for name, row in zip(names, record.willing_final, strict=True)
        }
    return out


def final_allocation(
    ids: np.ndarray, assigned: np.ndarray, phase: PhaseRecord
) -> tuple[np.ndarray, np.ndarray]:
    """Each task once (in the order of its first announcement) with the robot of its last
    allocation, or -1 if its last allocation was abandoned or it was never allocated."""
    if not ids.size:
        return ids, assigned
    _, first = np.unique(ids, return_index=True)
    rev_ids = ids[::-1]
    uniq, last_rev = np.unique(rev_ids, return_index=True)
    last_robot = dict(zip(uniq.tolist(), assigned[::-1][last_rev].tolist(), strict=True))
    fate = {row[0]: row[1] for row in phase.fate_rows}
    order = ids[np.sort(first)]
    out = np.array(
        [
            last_robot[t] if fate.get(t, "") not in ("lost", "abandoned_lost") else -1
            for t in order.tolist()
        ],
        dtype=assigned.dtype,
    )
    return order, out


def fault_summary(scenario: Scenario, record: RunRecord) -> dict:
    """What the robot faults did: test-phase fates and abandonments, and per robot its
    breakdowns and availability (share of the whole run, learning and test, not broken)."""
    test = record.test
    names = [r.name for r in scenario.robots]
    avail = record.availability
    fails = record.failures
    return {
        "fates": dict(zip(FATES, test.fates.tolist(), strict=True)),
        "abandoned": int(test.abandon_ends.sum()),
        "abandon_ends": dict(zip(ABANDON_ENDS, test.abandon_ends.tolist(), strict=True)),
        "requeued": int(test.abandon_ends[ABANDON_ENDS.index("requeued")]),
        "availability": {
            "mean": float(np.mean(avail)) if avail is not None else float("nan"),
            "per_robot": dict(zip(names, avail.tolist(), strict=True)) if avail is not None else {},
        },
        "failures_per_robot": dict(zip(names, fails.tolist(), strict=True))
        if fails is not None
        else {},
        "mttf_s": float(scenario.faults.mttf_s),
        "policy": scenario.faults.policy,
    }


def spatial_metrics(scenario: Scenario, stream: TaskStream, record: RunRecord, cost: str) -> dict:
    """Test-phase task figures of a spatial run: distance, waiting, finishing, estimate error.

    ``time_to_start_s`` is allocation to arrival (the task's work starts), ``time_to_finish_s``
    allocation to done; since a task is allocated when it is announced, the waiting time of a
    high-priority task is its time to start. ``estimate_error`` compares the bid with what
    really happened: metres driven for the distance cost, seconds to finish for the time cost
    (NaN for the abstract cost, whose bids are not physical).
    """
    comps = [c for c in record.test.completions if c.ok]
    exec_s = np.asarray(scenario.exec_time_s, dtype=float)
    if not comps:
        nan = float("nan")
        keys = (
            "distance_m",
            "distance_per_task_m",
            "time_to_start_s",
            "time_to_finish_s",
            "high_wait_s",
            "estimate_error",
        )
        return {**dict.fromkeys(keys, nan), "tasks_failed": len(record.test.completions)}
    ids = np.array([c.task_id for c in comps])
    dist = np.array([c.distance_m for c in comps])
    finish = np.array([c.t_done_s - c.t_alloc_s for c in comps])
    start = finish - exec_s[stream.types[ids]]
    bid = np.array([c.bid for c in comps])
    actual = {"distance": dist, "time": finish}.get(cost)
    high = stream.high[ids]
    return {
        "distance_m": float(dist.sum()),
        "distance_per_task_m": float(dist.mean()),
        "time_to_start_s": float(start.mean()),
        "time_to_finish_s": float(finish.mean()),
        "high_wait_s": float(start[high].mean()) if high.any() else float("nan"),
        "estimate_error": float(np.mean(actual - bid)) if actual is not None else float("nan"),
        "estimate_abs_error": float(np.mean(np.abs(actual - bid)))
        if actual is not None
        else float("nan"),
        "tasks_failed": len(record.test.completions) - len(comps),
    }


def spatial_per_robot(scenario: Scenario, record: RunRecord) -> dict:
    """Per robot, test sets: tasks completed, metres driven per completed task (None if none)."""
    out = {}
    for j, robot in enumerate(scenario.robots):
        dist = [c.distance_m for c in record.test.completions if c.ok and c.robot == j]
        out[robot.name] = {
            "tasks_done": len(dist),
            "distance_per_task_m": float(np.mean(dist)) if dist else None,
        }
    return out


def completion_table(scenario: Scenario, stream: TaskStream, record: RunRecord) -> dict:
    """Test-phase allocated tasks as columns: what was bid and what really happened."""
    comps = record.test.completions
    ids = np.array([c.task_id for c in comps], dtype=int)
    exec_s = np.asarray(scenario.exec_time_s, dtype=float)[stream.types[ids]]
    t_alloc = np.array([c.t_alloc_s for c in comps])
    t_done = np.array([c.t_done_s for c in comps])
    out = {
        "task": ids.tolist(),
        "type": [scenario.task_types[i] for i in stream.types[ids]],
        "high": stream.high[ids].tolist(),
        "robot": [scenario.robots[c.robot].name for c in comps],
        "bid": [c.bid for c in comps],
        "distance_m": [c.distance_m for c in comps],
        "time_to_start_s": (t_done - exec_s - t_alloc).tolist(),
        "time_to_finish_s": (t_done - t_alloc).tolist(),
        "ok": [c.ok for c in comps],
        "reason": [c.reason for c in comps],
    }
    if scenario.has_faults:
        _fault_rows(scenario, stream, record, out)
    return out


def _fault_rows(scenario: Scenario, stream: TaskStream, record: RunRecord, table: dict) -> None:
    """Robot faults: every row gets the task's final ``fate`` and its ``abandons`` (times its
    robot broke while doing it), and each abandonment gets a row of its own (ok false, reason
    'abandoned: robot broke', time_to_finish_s the time until the robot broke)."""
    fates = {row[0]: (row[1], row[2]) for row in record.test.fate_rows}
    aband = record.test.abandons
    ids = np.array([a.task_id for a in aband], dtype=int)
    types = stream.types[ids]
    table["task"] += ids.tolist()
    table["type"] += [scenario.task_types[i] for i in types]
    table["high"] += stream.high[ids].tolist()
    table["robot"] += [scenario.robots[a.robot].name for a in aband]
    table["bid"] += [a.bid for a in aband]
    table["distance_m"] += [float("nan")] * len(aband)
    table["time_to_start_s"] += [float("nan")] * len(aband)
    table["time_to_finish_s"] += [a.t_s - a.t_alloc_s for a in aband]
    table["ok"] += [False] * len(aband)
    table["reason"] += ["abandoned: robot broke"] * len(aband)
    table["fate"] = [fates[t][0] for t in table["task"]]
    table["abandons"] = [fates[t][1] for t in table["task"]]


def ci95(values: list[float]) -> float:
    """Half-width of the two-sided 95% Student-t confidence interval of the mean."""
    arr = np.asarray([v for v in values if not math.isnan(v)], dtype=float)
    if arr.size < 2:
        return float("nan")
    return float(stats.t.ppf(0.975, arr.size - 1) * arr.std(ddof=1) / math.sqrt(arr.size))


def _mean(values: list[float]) -> float:
    arr = np.asarray([v for v in values if not math.isnan(v)], dtype=float)
    return float(arr.mean()) if arr.size else float("nan")


def _stat_tree(runs: list[dict], get) -> tuple[dict, dict, dict]:
    """(means, ci95, per-seed lists) for a nested dict of numbers picked by ``get``."""
    first = get(runs[0])
    if isinstance(first, dict):
        parts = {k: _stat_tree(runs, lambda r, k=k: get(r)[k]) for k in first}
        return tuple({k: v[n] for k, v in parts.items()} for n in range(3))  # type: ignore[return-value]
    values = [get(r) for r in runs]
    return _mean(values), ci95(values), values


def aggregate(runs: list[dict]) -> dict:
    """Combine per-seed summaries of one allocator into its metrics.json entry."""
    mean, half, per_seed = _stat_tree(runs, lambda r: r["completion"])
    out: dict[str, Any] = {
        "completion": {**mean, "ci95": half, "per_seed": per_seed},
        "tasks": {
            "announced": sum(r["tasks"]["announced"] for r in runs),
            "allocated": sum(r["tasks"]["allocated"] for r in runs),
            "per_seed": [r["tasks"] for r in runs],
        },
        "lost": {  # test-set tasks lost, summed over seeds, by cause (learning.episode)
            cause: sum(r["lost"][cause] for r in runs) for cause in runs[0]["lost"]
        },
        "willing_per_type": {  # robots still willing at the end, mean over seeds
            t: _mean([r["willing_per_type"][t] for r in runs]) for t in runs[0]["willing_per_type"]
        },
        "offered_load": runs[0]["offered_load"],
    }
    if "learning_space" in runs[0]:
        spaces = [r["learning_space"] for r in runs]
        finals = [s["final"] for s in spaces]
        robots = list(spaces[0]["per_robot_final"])
        out["learning_space"] = {
            "initial": spaces[0]["initial"],
            "final": _mean(finals),
            "final_ci95": ci95(finals),
            "joint_log10": _mean([s["joint_log10"] for s in spaces]),
            "joint_log10_initial": spaces[0]["joint_log10_initial"],
            "per_robot_initial": spaces[0]["per_robot_initial"],
            "per_robot_final": {
                name: _mean([s["per_robot_final"][name] for s in spaces]) for name in robots
            },
            "per_seed": {
                "final": finals,
                "per_robot_final": [s["per_robot_final"] for s in spaces],
            },
        }
        kept = [r["experienced_tasks"] for r in runs]
        out["experienced_tasks"] = kept[0]
        out["experienced_tasks_share"] = {
            name: {t: sum(t in k[name] for k in kept) / len(kept) for t in _types_of(runs[0], name)}
            for name in robots
        }
    if "faults" in runs[0]:
        out["faults"] = aggregate_faults(runs)
    if "spatial" in runs[0]:
        mean, half, per_seed = _stat_tree(runs, lambda r: r["spatial"])
        out["spatial"] = {**mean, "ci95": half, "per_seed": per_seed}
    notes = null_notes(runs, out)
    if notes:
        out["notes"] = notes
    return out


def aggregate_faults(runs: list[dict]) -> dict:
    """Fault entries of several seeds: counts summed, availability averaged, per seed kept."""
    f0 = runs[0]["faults"]
    robots = list(f0["availability"]["per_robot"])
    return {
        "fates": {k: sum(r["faults"]["fates"][k] for r in runs) for k in f0["fates"]},
        "abandoned": sum(r["faults"]["abandoned"] for r in runs),
        "abandon_ends": {
            k: sum(r["faults"]["abandon_ends"][k] for r in runs) for k in f0["abandon_ends"]
        },
        "requeued": sum(r["faults"]["requeued"] for r in runs),
        "availability": {
            "mean": _mean([r["faults"]["availability"]["mean"] for r in runs]),
            "per_robot": {
                n: _mean([r["faults"]["availability"]["per_robot"][n] for r in runs])
                for n in robots
            },
        },
        "failures_per_robot": {
            n: sum(r["faults"]["failures_per_robot"][n] for r in runs) for n in robots
        },
        "mttf_s": f0["mttf_s"],
        "policy": f0["policy"],
        "per_seed": [r["faults"] for r in runs],
    }


def null_notes(runs: list[dict], agg: dict) -> list[str]:
    """Why values of an aggregate are null in metrics.json (JSON has no NaN)."""
    notes = []
    if len(runs) < 2:
        notes.append("ci95 values are null: a 95% interval needs at least 2 seeds")
    ratios = [v for t in agg["completion"]["by_type"].values() for v in t.values()]
    if any(isinstance(v, float) and math.isnan(v) for v in ratios):
        notes.append(
            "a null completion ratio: no task of that type and priority was announced on the "
            "test sets"
        )
    spatial = agg.get("spatial")
    if spatial is not None and math.isnan(spatial.get("estimate_error", 0.0)):
        notes.append(
            "estimate_error is null: abstract bids are not physical quantities (or no task "
            "was completed)"
        )
    return notes


def _types_of(run: dict, robot: str) -> list[str]:
    """Task types a robot could do at the start (its Table 1 row), from the summary."""
    return run["capabilities"][robot]
