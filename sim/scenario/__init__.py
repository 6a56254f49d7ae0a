"""Scenario types: frozen, slotted dataclasses in SI units that check themselves.

A scenario is pure data. It is loaded from a TOML file by ``scenarios.loader`` or built in
Python; either way every spec checks its settings when it is built (``schema``), so every door
gives the same one-line :class:`ScenarioError`. Everything downstream (worlds, cost models,
allocators) reads it and never changes it.

- ``schema``: how a setting is declared (type, default, unit, range, words, doc) and checked;
- ``core``: :class:`Scenario` and the tables of the abstract world (robots, stream, learning,
  experience, faults);
- ``spatial``: the ``[spatial]`` table and its sub-tables (robot body, laws, avoidance, sites'
  queues, recovery, jams, stall meter, contact solver);
- ``maps``: a ROS map as the arena (``map_arena``), for the file door and ``SpatialSpec.on_map``.
"""

from sim.scenario.core import (
    FAULT_POLICIES,
    MAX_EXEC_S,
    MAX_HISTORY_SPACE,
    MAX_ROBOTS,
    MAX_TASKS,
    MAX_TYPES,
    REFUSAL_RULES,
    REPAIR_KINDS,
    ExperienceSpec,
    FaultSpec,
    LearningSpec,
    RobotSpec,
    Scenario,
    StreamSpec,
)
from sim.scenario.schema import ScenarioError, did_you_mean
from sim.scenario.spatial import (
    AVOIDANCE,
    LOOK_AHEAD,
    ContactSpec,
    DriveSpec,
    FollowSpec,
    JamSpec,
    LawSpec,
    MakeWaySpec,
    OrcaSpec,
    QueueSpec,
    RecoverySpec,
    SpatialSpec,
    StallSpec,
)

__all__ = [
    "AVOIDANCE",
    "FAULT_POLICIES",
    "LOOK_AHEAD",
    "MAX_EXEC_S",
    "MAX_HISTORY_SPACE",
    "MAX_ROBOTS",
    "MAX_TASKS",
    "MAX_TYPES",
    "REFUSAL_RULES",
    "REPAIR_KINDS",
    "ContactSpec",
    "DriveSpec",
    "ExperienceSpec",
    "FaultSpec",
    "FollowSpec",
    "JamSpec",
    "LawSpec",
    "LearningSpec",
    "MakeWaySpec",
    "OrcaSpec",
    "QueueSpec",
    "RecoverySpec",
    "RobotSpec",
    "Scenario",
    "ScenarioError",
    "SpatialSpec",
    "StallSpec",
    "StreamSpec",
    "did_you_mean",
]
