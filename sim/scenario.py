"""Scenario types: frozen, slotted dataclasses in SI units.

A scenario is pure data. It is loaded and validated by ``scenarios.loader``; everything
downstream (worlds, cost models, allocators) reads it and never changes it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, slots=True)
class RobotSpec:
    """One robot: its name, the task types it can do and (spatial worlds) where it starts."""

    name: str
    capabilities: tuple[int, ...]  # indices into Scenario.task_types
    start_xy: tuple[float, float] | None = None  # m
    heading_deg: float = 0.0  # initial heading from +x, counter-clockwise (spatial worlds)


@dataclass(frozen=True, slots=True)
class StreamSpec:
    """How tasks are announced (paper §6, SPEC §1)."""

    batch_min: int = 3
    batch_max: int = 7
    p_high: float = 0.35
    n_sets: int = 45
    rounds_per_set: int = 18  # 18 rounds x 5 tasks on average = about 90 tasks a set
    learn_sets: int = 30  # sets 1..learn_sets learn
    test_sets: int = 30  # the last test_sets sets are tested (they may overlap the learning sets)
    announce_interval_s: float = 10.0


@dataclass(frozen=True, slots=True)
class LearningSpec:
    """Tabular Q-learning parameters shared by QL-MRTA and ExpT-MRTA (SPEC §3)."""

    alpha: float = 0.1
    gamma: float = 0.9
    epsilon_start: float = 0.3
    epsilon_end: float = 0.02
    epsilon_decay: float = 0.9  # multiplied once per learning set
    history: int = 4
    reward_high: float = 5.0  # a high-priority task taken
    reward_low: float = 1.0  # a low-priority task taken
    penalty_lost_high: float = 5.0  # per capable high-priority task lost while busy with a low one


REFUSAL_RULES = ("paper", "reserve")


@dataclass(frozen=True, slots=True)
class ExperienceSpec:
    """ExpT-MRTA thresholds (SPEC §4) and the refusal rule.

    ``refusal = "paper"``: a refused type is never done again by the robot (paper §4.3).
    ``refusal = "reserve"``: a refused type leaves the robot's learning space and its regular
    bidding, but the robot stays a reserve for it: a task of the type that no willing robot
    took in its round goes to a free reserve robot in a second auction (plain cost bids).
    """

    delta_v: float = 0.2
    delta_u: float = 0.08
    n_min: int = 40
    coverage_k: int = 2
    sticky_b1: bool = True
    refusal: str = "reserve"


@dataclass(frozen=True, slots=True)
class DriveSpec:
    """Differential-drive robot body (spatial worlds)."""

    radius_m: float = 0.25
    mass_kg: float = 20.0
    wheel_base_m: float = 0.4
    wheel_radius_m: float = 0.08
    max_wheel_speed_radps: float = 18.75  # 1.5 m/s top speed with 0.08 m wheels
    max_wheel_accel_radps2: float = 25.0
    traction_mps2: float = 6.0  # motor/tyre force limit per kg: how hard a robot can push

    @property
    def max_speed_mps(self) -> float:
        return self.max_wheel_speed_radps * self.wheel_radius_m


@dataclass(frozen=True, slots=True)
class SpatialSpec:
    """Arena, obstacles and task sites of a spatial world (SPEC §6)."""

    width_m: float
    height_m: float
    obstacles: tuple[tuple[tuple[float, float], ...], ...]  # convex polygons, m
    sites: tuple[tuple[tuple[float, float], ...], ...]  # per task type: candidate task points, m
    drive: DriveSpec = field(default_factory=DriveSpec)
    dt_s: float = 1.0 / 60.0
    control_hz: float = 20.0
    arrive_tol_m: float = 0.3
    grid_res_m: float = 0.25
    stuck_timeout_s: float = 20.0
    clearance_m: float = 0.1  # planned paths keep this much space beyond the robot radius
    max_recoveries: int = 3  # back-off-and-replan attempts before a task is reported failed
    collision_slop_m: float = 0.005  # pymunk's allowed overlap, in metres
    avoidance: str = (
        "orca"  # reciprocal collision avoidance (sim.spatial.law.orca); "none": proximity law
    )
    look_ahead: str = (
        "off"  # "on": plan round robots at work in the way (sim.spatial.jams.Jams.look_ahead)
    )


FAULT_POLICIES = ("requeue", "drop")
REPAIR_KINDS = ("fixed", "exponential")


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

    mttf_s: float = float("inf")
    mttf_by_robot: tuple[tuple[str, float], ...] = ()  # (robot name, mean time to failure s)
    repair_s: float = 60.0
    repair: str = "fixed"
    p_permanent: float = 0.0
    policy: str = "requeue"

    def mttf_per_robot(self, names) -> np.ndarray:
        """(m,) mean time to failure of each robot, s (inf: never breaks)."""
        own = dict(self.mttf_by_robot)
        return np.array([own.get(n, self.mttf_s) for n in names], dtype=float)

    def enabled(self, names) -> bool:
        """True if some robot can break."""
        return bool(np.isfinite(self.mttf_per_robot(names)).any())


@dataclass(frozen=True, slots=True)
class Scenario:
    """The whole experiment: robots, task types, costs, stream and allocator parameters."""

    name: str
    task_types: tuple[str, ...]
    robots: tuple[RobotSpec, ...]
    cost: tuple[tuple[float, ...], ...]  # abstract cost c(R_j, T_i); inf where incapable
    exec_time_s: tuple[float, ...]  # per task type
    stream: StreamSpec = field(default_factory=StreamSpec)
    learning: LearningSpec = field(default_factory=LearningSpec)
    experience: ExperienceSpec = field(default_factory=ExperienceSpec)
    spatial: SpatialSpec | None = None
    faults: FaultSpec = field(default_factory=FaultSpec)
    source: str = ""  # file the scenario came from
    source_sha256: str = ""

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
