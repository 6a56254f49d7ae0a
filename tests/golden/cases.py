"""Fixed-seed golden runs: the metrics and trajectories a behaviour-preserving change keeps.

``python tests/golden/cases.py`` rewrites ``golden.json``; do that only for a change that is
meant to alter results, and say so in its commit message. The test (``tests/test_golden.py``)
recomputes every case and compares it with the file bit for bit.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
GOLDEN = HERE / "golden.json"

PAPER_RULE = (("experience.refusal", "paper"),)
RESERVE_RULE = (("experience.refusal", "reserve"),)
SHORT_ABSTRACT = (
    ("stream.n_sets", 10),
    ("stream.learn_sets", 7),
    ("stream.test_sets", 5),
    ("experience.n_min", 8),
    ("experience.delta_u", 0.3),
)
SHORT_SPATIAL = (
    ("stream.n_sets", 3),
    ("stream.rounds_per_set", 8),
    ("stream.learn_sets", 2),
    ("stream.test_sets", 2),
    ("experience.n_min", 4),
    ("experience.delta_u", 0.3),
)
NO_AVOIDANCE = (("spatial.avoidance", "none"),)  # today's law, as the cases were recorded
ORCA = (("spatial.avoidance", "orca"),)
FAULTS = (  # robots break every 2 min on average and are repaired in 30 s (sim.faults)
    ("faults.mttf_s", 120.0),
    ("faults.repair_s", 30.0),
    ("stream.n_sets", 3),
    ("stream.learn_sets", 2),
    ("stream.test_sets", 1),
)
SHORT_LARGE = (
    ("stream.n_sets", 1),
    ("stream.rounds_per_set", 6),
    ("stream.learn_sets", 1),
    ("stream.test_sets", 1),
)

# (case name, scenario, allocator, cost, seed, overrides, control path: None = by team size)
CASES = (
    ("abstract_market", "paper", "market", "abstract", 3, SHORT_ABSTRACT, None),
    ("abstract_ql", "paper", "ql", "abstract", 3, SHORT_ABSTRACT, None),
    ("abstract_expt", "paper", "expt", "abstract", 3, PAPER_RULE + SHORT_ABSTRACT, None),
    ("abstract_expt_reserve", "paper", "expt", "abstract", 3, RESERVE_RULE + SHORT_ABSTRACT, None),
    (
        "spatial_expt_distance_scalar",
        "paper_spatial",
        "expt",
        "distance",
        1,
        SHORT_SPATIAL + NO_AVOIDANCE,
        "scalar",
    ),
    (
        "spatial_market_time_array",
        "paper_spatial",
        "market",
        "time",
        2,
        SHORT_SPATIAL + NO_AVOIDANCE,
        "array",
    ),
    ("spatial_large_ql_distance", "large", "ql", "distance", 0, SHORT_LARGE + NO_AVOIDANCE, None),
    (
        "spatial_orca_expt_distance_scalar",
        "paper_spatial",
        "expt",
        "distance",
        1,
        SHORT_SPATIAL + ORCA,
        "scalar",
    ),
    (
        "spatial_orca_market_time_array",
        "paper_spatial",
        "market",
        "time",
        2,
        SHORT_SPATIAL + ORCA,
        "array",
    ),
    # broken robots stand where they broke and every planner of the world plans round them
    ("spatial_orca_faults_warehouse", "warehouse", "market", "distance", 0, FAULTS + ORCA, None),
)


def digest(array: np.ndarray) -> str:
    """SHA-256 of an array's dtype, shape and bytes."""
    a = np.ascontiguousarray(array)
    h = hashlib.sha256(f"{a.dtype.str}{a.shape}".encode())
    h.update(a.tobytes())
    return h.hexdigest()


def run_case(scenario, allocator, cost, seed, overrides, control) -> dict:
    """One golden run: its summary (JSON text) and, in the pymunk world, trajectory digests."""
    from scenarios.protocol import RunSpec, execute
    from sim.recording import TrajectoryRecorder
    from tests.golden.control import forced_control

    spec = RunSpec(scenario, allocator, cost=cost, seed=seed, overrides=overrides)
    out: dict = {}
    if scenario == "paper":
        summary = execute(spec)
    else:
        from scenarios.protocol import build_run

        recorder = TrajectoryRecorder.for_scenario(build_run(spec)[0])
        with forced_control(control):
            summary = execute(spec, recorder=recorder, task_table=True)
        traj = recorder.finish()
        out["trajectory"] = {
            k: digest(getattr(traj, k))
            for k in (
                "times_s",
                "positions",
                "headings",
                "robot_state",
                "t_alloc",
                "t_done",
                "task_robot",
            )
        }
    out["summary"] = json.loads(json.dumps(summary, sort_keys=True, allow_nan=True))
    return out


def compute() -> dict:
    return {name: run_case(*args) for name, *args in CASES}


if __name__ == "__main__":
    sys.path.insert(0, str(HERE.parents[1]))
    GOLDEN.write_text(json.dumps(compute(), indent=1, sort_keys=True, allow_nan=True) + "\n")
    print(f"wrote {GOLDEN}")
