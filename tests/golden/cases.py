"""Fixed-seed golden runs: the metrics and trajectories a behaviour-preserving change keeps.

``python tests/golden/cases.py`` rewrites ``golden.json``; do that only for a change that is
meant to alter results, and say so in its commit message. The test
(``tests/golden/test_golden.py``) recomputes every case and compares it with the file bit for
bit.

The same on every x86-64 machine: both the writer and the test run the cases in a child Python
(:func:`compute_portable`) whose numpy uses only the SIMD kernels of its baseline
(``NPY_ENABLE_CPU_FEATURES``, :data:`PORTABLE_ENV`). numpy picks its kernels for exp, log,
arctan2, power and complex products by what the CPU has (AVX-512, AVX2, neither), and they
differ in the last bit: a run on an AVX-512 machine and one on an AVX2 machine part after a
few hundred simulated seconds. The simulation calls no BLAS (whose kernel, chosen per CPU
model, changed the last bits between an Intel and an AMD machine: README, "Reliability").
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
GOLDEN = HERE / "golden.json"
ROOT = HERE.parents[1]
# numpy's baseline kernels only (x86-64-v2; a name numpy does not know is ignored)
PORTABLE_ENV = {"NPY_ENABLE_CPU_FEATURES": "X86_V2"}
MACHINE = "x86_64"  # the architecture the golden file was written for

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


def compute(names=None) -> dict:
    """The cases ``names`` (default all) in this process (numpy's kernels as this CPU has
    them)."""
    return {name: run_case(*args) for name, *args in CASES if names is None or name in names}


def compute_portable(names=(), env=None) -> dict:
    """The cases ``names`` (default all) in a child Python with :data:`PORTABLE_ENV` (numpy's
    baseline kernels) and ``env``: the same bits on every x86-64 machine."""
    env = {**os.environ, **(env or {}), **PORTABLE_ENV, "PYTHONPATH": str(ROOT)}
    child = subprocess.run(
        [sys.executable, "-m", "tests.golden.cases", "--print", *names],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if child.returncode:
        raise RuntimeError(f"golden cases failed in the child process:\n{child.stderr[-4000:]}")
    return json.loads(child.stdout)


def in_baseline_child(module: str, call: str):
    """``call`` (an expression on the names of the Python file ``module``) evaluated in a child
    Python with :data:`PORTABLE_ENV` (numpy's baseline kernels); its value, through JSON."""
    env = {**os.environ, **PORTABLE_ENV, "PYTHONPATH": str(ROOT)}
    code = f"import json, runpy; ns = runpy.run_path({module!r}); print(json.dumps({call}))"
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def baseline_only() -> bool:
    """True if this process's numpy uses its baseline kernels only (no dispatched ones)."""
    from numpy._core import _multiarray_umath as umath

    return not any(umath.__cpu_features__.get(f, False) for f in umath.__cpu_dispatch__)


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    if "--print" in sys.argv:  # the child of compute_portable
        if not baseline_only():
            sys.exit(f"numpy dispatches SIMD kernels here: run with {PORTABLE_ENV}")
        names = sys.argv[sys.argv.index("--print") + 1 :] or None
        print(json.dumps(compute(names), sort_keys=True, allow_nan=True))
    else:
        if platform.machine() != MACHINE:
            sys.exit(f"golden.json is written on {MACHINE}, this is {platform.machine()}")
        text = json.dumps(compute_portable(), indent=1, sort_keys=True, allow_nan=True)
        GOLDEN.write_text(text + "\n")
        print(f"wrote {GOLDEN}")
