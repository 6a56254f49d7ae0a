"""The scenario and its abstract-world tables: robots, stream, learning, experience, faults.

Frozen, slotted dataclasses in SI units. Each checks itself when it is built
(:func:`sim.scenario.schema.check_settings` against the declarations below, then its own
cross-field rules), so a scenario built in Python gets the same one-line errors as a file.
The ``[spatial]`` table is :class:`sim.scenario.spatial.SpatialSpec`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from sim.scenario.schema import (
    ScenarioError,
    check_settings,
    check_value,
    did_you_mean,
    fail,
    kind_of,
    required,
    setting,
    table,
)
from sim.scenario.spatial import SpatialSpec

MAX_ROBOTS = 5000
MAX_TYPES = 200
MAX_TASKS = 5_000_000  # sets x rounds x batch_max: beyond this a stream would not fit in memory
MAX_HISTORY_SPACE = 50_000_000  # largest per-robot Q-table (entries) we agree to allocate
MAX_EXEC_S = 86_400.0  # a task's execution time, s: at most a day
REFUSAL_RULES = ("paper", "reserve")
FAULT_POLICIES = ("requeue", "drop")
REPAIR_KINDS = ("fixed", "exponential")


@dataclass(frozen=True, slots=True)
class RobotSpec:
    """One robot: its name, the task types it can do and (spatial worlds) where it starts.

    Checked by the :class:`Scenario` that holds it (which knows its index, ``robots[j]``).
    """

    name: str
    capabilities: tuple[int, ...]  # indices into Scenario.task_types
    start_xy: tuple[float, float] | None = None  # m
    heading_deg: float = setting(
        0.0,
        "initial heading from +x, counter-clockwise (spatial worlds)",
        unit="deg",
        lo=-360.0,
        hi=360.0,
    )


@dataclass(frozen=True, slots=True)
class StreamSpec:
    """How tasks are announced (``[stream]``; paper §6)."""

    SECTION: ClassVar[str] = "stream"
    batch_min: int = setting(3, "fewest tasks announced in a round", lo=1, hi=10_000)
    batch_max: int = setting(
        7, "most tasks announced in a round (uniform from batch_min)", lo=1, hi=10_000
    )
    p_high: float = setting(0.35, "probability that a task is high priority", lo=0.0, hi=1.0)
    n_sets: int = setting(45, "task sets in a run", lo=1, hi=100_000)
    rounds_per_set: int = setting(
        18, "announcement rounds per set (18 x 5 tasks: about 90 a set)", lo=1, hi=1_000_000
    )
    learn_sets: int = setting(30, "sets 1..learn_sets learn (explore, update Q)", lo=1, hi=100_000)
    test_sets: int = setting(
        30,
        "the last test_sets sets are tested (they may overlap the learning sets)",
        lo=1,
        hi=100_000,
    )
    announce_interval_s: float = setting(
        10.0, "time between announcements", unit="s", lo=0.0, lo_open=True, hi=86_400.0
    )

    def __post_init__(self) -> None:
        check_settings(self, self.SECTION)
        if self.batch_max < self.batch_min:
            fail("stream.batch_max", "must be >= stream.batch_min")
        for key in ("learn_sets", "test_sets"):
            if getattr(self, key) > self.n_sets:
                fail(f"stream.{key}", f"must be in 1..n_sets ({self.n_sets})")
        n_tasks = self.n_sets * self.rounds_per_set * self.batch_max
        if n_tasks > MAX_TASKS:
            fail("stream", f"up to {n_tasks:,} tasks: more than {MAX_TASKS:,}")


@dataclass(frozen=True, slots=True)
class LearningSpec:
    """Tabular Q-learning of QL-MRTA and ExpT-MRTA (``[learning]``; SPEC §3)."""

    SECTION: ClassVar[str] = "learning"
    alpha: float = setting(0.1, "learning rate", lo=0.0, lo_open=True, hi=1.0)
    gamma: float = setting(0.9, "discount", lo=0.0, hi=1.0, hi_open=True)
    epsilon_start: float = setting(0.3, "exploration rate in the first learning set", lo=0, hi=1)
    epsilon_end: float = setting(0.02, "exploration rate it decays to", lo=0.0, hi=1.0)
    epsilon_decay: float = setting(
        0.9, "factor applied to the exploration rate once per learning set", lo=0.0, hi=1.0
    )
    history: int = setting(
        4,
        "h: task types of the state (the last h announced that the robot can do)",
        lo=1,
        hi=1000,
    )
    reward_high: float = setting(5.0, "reward for a high-priority task taken", lo=0, hi=1e6)
    reward_low: float = setting(1.0, "reward for a low-priority task taken", lo=0.0, hi=1e6)
    penalty_lost_high: float = setting(
        5.0,
        "penalty per capable high-priority task lost while busy with a low one",
        lo=0.0,
        hi=1e6,
    )

    def __post_init__(self) -> None:
        check_settings(self, self.SECTION)


@dataclass(frozen=True, slots=True)
class ExperienceSpec:
    """ExpT-MRTA's thresholds and refusal rule (``[experience]``; SPEC §4).

    ``refusal = "paper"``: a refused type is never done again by the robot (paper §4.3).
    ``refusal = "reserve"``: a refused type leaves the robot's learning space and its regular
    bidding, but the robot stays a reserve for it: a task of the type that no willing robot
    took in its round goes to a free reserve robot in a second auction (plain cost bids).
    """

    SECTION: ClassVar[str] = "experience"
    delta_v: float = setting(
        0.2, "B0 -> B1 (eager or hesitant) once |TEP - 1| >= delta_v", lo=0.0, hi=1.0
    )
    delta_u: float = setting(
        0.08,
        "refuse a type once TEM < delta_u (after n_min observations)",
        lo=0.0,
        hi=2.0,
        note="TEM lies in (0, 2)",
    )
    n_min: int = setting(40, "observations of a type before it may be refused", lo=1, hi=10**9)
    coverage_k: int = setting(
        2, "no refusal that leaves a type fewer than k willing robots", lo=1, hi=MAX_ROBOTS
    )
    sticky_b1: bool = setting(True, "once eager or hesitant, a robot stays so for the type")
    refusal: str = setting(
        "reserve",
        "what a refused type means: never again (paper) or a reserve robot (reserve)",
        choices=REFUSAL_RULES,
    )

    def __post_init__(self) -> None:
        check_settings(self, self.SECTION)


@dataclass(frozen=True, slots=True)
class FaultSpec:
    """Robot breakdowns (``[faults]``; every key optional, no table or an empty one: none).

    Each robot's time to failure is exponential with mean ``mttf_s`` (``mttf_by_robot`` names
    robots with their own mean); ``inf`` means the robot never breaks. A broken robot is out
    for ``repair_s`` seconds (``repair = "fixed"``) or for an exponential time of that mean
    (``"exponential"``); with probability ``p_permanent`` a failure is for good. The task a
    robot was doing when it broke is re-announced in the next round (``policy = "requeue"``)
    or lost at once (``"drop"``).
    """

    SECTION: ClassVar[str] = "faults"
    mttf_s: float = setting(
        math.inf,
        "mean time to failure of every robot (inf: never breaks)",
        unit="s",
        lo=0.0,
        lo_open=True,
        hi=1e12,
        inf_ok=True,
        note="or inf: never breaks",
    )
    mttf_by_robot: tuple[tuple[str, float], ...] = ()  # (robot name, mean time to failure s)
    repair_s: float = setting(60.0, "repair time (or its mean)", unit="s", lo=0.0, hi=1e12)
    repair: str = setting(
        "fixed", "repair time: fixed, or exponential with mean repair_s", choices=REPAIR_KINDS
    )
    p_permanent: float = setting(0.0, "probability that a failure is for good", lo=0.0, hi=1.0)
    policy: str = setting(
        "requeue",
        "the broken robot's task: re-announced next round, or dropped (lost)",
        choices=FAULT_POLICIES,
    )

    def __post_init__(self) -> None:
        check_settings(self, self.SECTION)
        own = self.mttf_by_robot
        if isinstance(own, dict):
            own = tuple(own.items())
        if not isinstance(own, tuple | list):
            fail("faults.mttf_by_robot", f"must be a table, got {kind_of(own)}")
        pairs = []
        meta = type(self).__dataclass_fields__["mttf_s"].metadata["setting"]
        for pair in own:
            name, val = pair
            where = f"faults.mttf_by_robot.{name}"
            pairs.append((str(name), check_value(val, float, meta, where)))
        object.__setattr__(self, "mttf_by_robot", tuple(pairs))

    def mttf_per_robot(self, names) -> np.ndarray:
        """(m,) mean time to failure of each robot, s (inf: never breaks)."""
        own = dict(self.mttf_by_robot)
        return np.array([own.get(n, self.mttf_s) for n in names], dtype=float)

    def enabled(self, names) -> bool:
        """True if some robot can break."""
        return bool(np.isfinite(self.mttf_per_robot(names)).any())


@dataclass(frozen=True, slots=True)
class Scenario:
    """The whole experiment: robots, task types, costs, stream and allocator parameters.

    Built from a file (``scenarios.loader.load_scenario``) or in Python; either way it checks
    itself here (``ScenarioError``: one line naming the key). The spatial layout (starts, sites,
    reachability) is checked by ``sim.spatial.layout.check_layout`` when a pymunk world is
    built and when a file is loaded.
    """

    name: str
    task_types: tuple[str, ...]
    robots: tuple[RobotSpec, ...]
    cost: tuple[tuple[float, ...], ...]  # abstract cost c(R_j, T_i); inf where incapable
    exec_time_s: tuple[float, ...] = required(
        "execution time per task type", unit="s", lo=0.0, hi=MAX_EXEC_S
    )
    stream: StreamSpec = table(StreamSpec, "how tasks are announced")
    learning: LearningSpec = table(LearningSpec, "QL-MRTA's and ExpT-MRTA's Q-learning")
    experience: ExperienceSpec = table(ExperienceSpec, "ExpT-MRTA's experience thresholds")
    spatial: SpatialSpec | None = None
    faults: FaultSpec = table(FaultSpec, "robot breakdowns")
    source: str = ""  # file the scenario came from
    source_sha256: str = ""

    def __post_init__(self) -> None:
        _check_scenario(self)

    @property
    def n_robots(self) -> int:
        return len(self.robots)

    @property
    def n_types(self) -> int:
        return len(self.task_types)

    @property
    def has_faults(self) -> bool:
        """True if the ``[faults]`` table lets some robot break."""
        return self.faults.enabled([r.name for r in self.robots])

    def capability_matrix(self) -> np.ndarray:
        """Boolean (robots x types) matrix: True where the robot can do the type."""
        cap = np.zeros((self.n_robots, self.n_types), dtype=bool)
        for j, robot in enumerate(self.robots):
            cap[j, list(robot.capabilities)] = True
        return cap

    def cost_matrix(self) -> np.ndarray:
        """Abstract cost (robots x types), ``inf`` where the robot is not capable."""
        cost = np.array(self.cost, dtype=float)
        cost[~self.capability_matrix()] = np.inf
        return cost

    def test_set_indices(self) -> range:
        """Zero-based indices of the test sets: the last ``test_sets`` sets."""
        return range(self.stream.n_sets - self.stream.test_sets, self.stream.n_sets)


def _set(obj: Any, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


def _check_scenario(sc: Scenario) -> None:
    """Every rule of a whole scenario that no single table can check alone."""
    if not isinstance(sc.name, str) or not sc.name.strip():
        fail("scenario.name", f"must be a non-empty string, got {kind_of(sc.name)}")
    types = tuple(sc.task_types) if isinstance(sc.task_types, list | tuple) else None
    if types is None or not all(isinstance(t, str) and t for t in types):
        fail("scenario.task_types", f"must be a list of strings, got {kind_of(sc.task_types)}")
    if not 1 <= len(types) <= MAX_TYPES:
        fail("scenario.task_types", f"needs 1 to {MAX_TYPES} entries, got {len(types)}")
    if len(set(types)) != len(types):
        fail("scenario.task_types", "duplicate task type names")
    _set(sc, "task_types", types)
    n = len(types)
    _check_exec(sc, n)
    for key, cls in (
        ("stream", StreamSpec),
        ("learning", LearningSpec),
        ("experience", ExperienceSpec),
        ("faults", FaultSpec),
    ):
        if not isinstance(getattr(sc, key), cls):
            fail(key, f"must be a {cls.__name__}, got {kind_of(getattr(sc, key))}")
    if sc.spatial is not None and not isinstance(sc.spatial, SpatialSpec):
        fail("spatial", f"must be a SpatialSpec or None, got {kind_of(sc.spatial)}")
    robots = tuple(sc.robots) if isinstance(sc.robots, list | tuple) else ()
    if not robots:
        fail("robots", "needs at least one [[robots]] table")
    if len(robots) > MAX_ROBOTS:
        fail("robots", f"{len(robots)} robots, more than the {MAX_ROBOTS} we support")
    _set(sc, "robots", robots)
    _check_robots(sc, types)
    _check_cost(sc, types)
    covered = {i for r in robots for i in r.capabilities}
    for i, t in enumerate(types):
        if i not in covered:
            fail("scenario.task_types", f"task type {t!r} cannot be done by any robot")
    widest = max(len(r.capabilities) for r in robots)
    h = sc.learning.history
    if h * math.log(max(widest, 1)) > math.log(MAX_HISTORY_SPACE):  # no huge int powers
        digits = h * math.log10(widest) + math.log10(2)
        fail(
            "learning.history",
            f"a robot's Q-table would have about 10^{digits:.0f} entries "
            f"(limit {MAX_HISTORY_SPACE:,})",
        )
    names = [r.name for r in robots]
    for name, _ in sc.faults.mttf_by_robot:
        if name not in names:
            fail(
                f"faults.mttf_by_robot.{name}",
                f"no robot named {name!r}{did_you_mean(name, names)}",
            )
    if sc.spatial is not None:
        _check_spatial(sc, types)


def _check_exec(sc: Scenario, n: int) -> None:
    val = sc.exec_time_s
    if not isinstance(val, list | tuple | np.ndarray):
        fail("scenario.exec_time_s", f"must be a list of {n} numbers, got {kind_of(val)}")
    if len(val) != n:
        fail("scenario.exec_time_s", f"must have {n} entries, got {len(val)}")
    meta = Scenario.__dataclass_fields__["exec_time_s"].metadata["setting"]
    out = tuple(
        check_value(x, float, meta, f"scenario.exec_time_s[{i}]") for i, x in enumerate(val)
    )
    _set(sc, "exec_time_s", out)


def _check_robots(sc: Scenario, types: tuple[str, ...]) -> None:
    seen: set[str] = set()
    for j, robot in enumerate(sc.robots):
        where = f"robots[{j}]"
        if not isinstance(robot, RobotSpec):
            fail(where, f"must be a RobotSpec, got {kind_of(robot)}")
        if not isinstance(robot.name, str) or not robot.name.strip():
            fail(f"{where}.name", f"must be a non-empty string, got {kind_of(robot.name)}")
        if robot.name in seen:
            fail(f"{where}.name", f"duplicate robot name {robot.name!r}")
        seen.add(robot.name)
        caps = robot.capabilities
        if not isinstance(caps, list | tuple) or not all(
            isinstance(c, int | np.integer) and not isinstance(c, bool) for c in caps
        ):
            fail(f"{where}.capabilities", "must be a list of task type indices")
        if not 1 <= len(caps) <= len(types):
            fail(f"{where}.capabilities", f"needs 1 to {len(types)} entries, got {len(caps)}")
        if len(set(caps)) != len(caps):
            fail(f"{where}.capabilities", "a task type is listed twice")
        bad = [c for c in caps if not 0 <= c < len(types)]
        if bad:
            fail(f"{where}.capabilities", f"task type index {bad[0]} outside 0..{len(types) - 1}")
        _set(robot, "capabilities", tuple(sorted(int(c) for c in caps)))
        check_settings(robot, where)
        if robot.start_xy is not None:
            start = robot.start_xy
            if not isinstance(start, list | tuple | np.ndarray) or len(start) != 2:
                fail(f"{where}.start", "must be a point [x, y]")
            meta = RobotSpec.__dataclass_fields__["heading_deg"].metadata["setting"]
            free = type(meta)(meta.doc, unit="m")
            xy = tuple(
                check_value(x, float, free, f"{where}.start[{i}]") for i, x in enumerate(start)
            )
            _set(robot, "start_xy", xy)


def _check_cost(sc: Scenario, types: tuple[str, ...]) -> None:
    rows = sc.cost
    if not isinstance(rows, list | tuple | np.ndarray) or len(rows) != len(sc.robots):
        fail("robots", f"cost must have one row per robot ({len(sc.robots)})")
    out = []
    for j, (robot, row) in enumerate(zip(sc.robots, rows, strict=True)):
        if not isinstance(row, list | tuple | np.ndarray) or len(row) != len(types):
            fail(f"robots[{j}].cost", f"must have one entry per task type ({len(types)})")
        clean = []
        for i, c in enumerate(row):
            where = f"robots[{j}].cost.{types[i]}"
            if i not in robot.capabilities:
                clean.append(math.inf)
                continue
            if isinstance(c, bool) or not isinstance(c, int | float | np.number):
                fail(where, f"must be a number, got {kind_of(c)}")
            c = float(c)
            if not math.isfinite(c):
                fail(where, f"must be finite, got {c}")
            if c < 0.0:
                fail(where, f"must be >= 0, got {c:g}")
            clean.append(c)
        out.append(tuple(clean))
    _set(sc, "cost", tuple(out))


def _check_spatial(sc: Scenario, types: tuple[str, ...]) -> None:
    """Sites per task type (named), and every robot's start."""
    sites = sc.spatial.sites
    if not isinstance(sites, list | tuple) or len(sites) != len(types):
        fail("spatial.sites", f"needs one list of points per task type ({len(types)})")
    out = []
    for i, pts in enumerate(sites):
        where = f"spatial.sites.{types[i]}"
        out.append(sc.spatial.site_points(pts, where))
    _set(sc.spatial, "sites", tuple(out))
    for j, robot in enumerate(sc.robots):
        if robot.start_xy is None:
            fail(f"robots[{j}].start", "missing: a spatial scenario needs start = [x, y]")


__all__ = [
    "FAULT_POLICIES",
    "MAX_EXEC_S",
    "MAX_HISTORY_SPACE",
    "MAX_ROBOTS",
    "MAX_TASKS",
    "MAX_TYPES",
    "REFUSAL_RULES",
    "REPAIR_KINDS",
    "ExperienceSpec",
    "FaultSpec",
    "LearningSpec",
    "RobotSpec",
    "Scenario",
    "ScenarioError",
    "StreamSpec",
]
