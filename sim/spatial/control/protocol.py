"""What a control period is: the one interface both implementations have, and what they work on.

A control period reads the robots' poses, advances their tasks, steers them, caps their speeds
near robots and obstacles, limits the wheels and writes the motor commands. It exists three times
with the same rules: compiled (``sim.spatial.control.compiled``, numba, for every team size), over
numpy arrays (``sim.spatial.control.array``) and robot by robot in plain Python
(``sim.spatial.control.scalar``) with the formulas of ``sim.spatial.law.drive``. They command the
same wheels up to rounding (the compiled one keeps wall lines hard in a velocity program with no
solution, a rule of its own), and each is bit-for-bit reproducible on its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from sim.spatial.controller import DiffDriveController
from sim.spatial.fleet import FleetState, Schedule
from sim.spatial.jobs import Jobs
from sim.spatial.law.orca import DEFAULT, OrcaLaw
from sim.spatial.motors import Motors
from sim.spatial.navigation.paths import PathFollower


@dataclass(frozen=True, slots=True)
class ControlParts:
    """The world's state and collaborators a control period works on, handed over once.

    Attributes:
        fleet: per-robot state, read and written in place.
        schedule: the schedule of checks, read and written.
        jobs: task bookkeeping, called on events.
        motors: the robots' bodies: poses read, commands written.
        follower: the robots' paths.
        controller: the drive limits and the law over arrays.
        arrive_tol_m: a robot this close to its site has arrived, m.
        reach_m: robot centres closer than this are touching, m.
        avoid: steer with ORCA (``sim.spatial.law.orca``) and without keep-right (``[spatial]
            avoidance = "orca"``); False: the proximity law alone.
        orca: ORCA's settings (``[spatial.orca]``).
    """

    fleet: FleetState
    schedule: Schedule
    jobs: Jobs
    motors: Motors
    follower: PathFollower
    controller: DiffDriveController
    arrive_tol_m: float
    reach_m: float
    avoid: bool = False
    orca: OrcaLaw = DEFAULT


class Control(Protocol):
    """One control period of the pymunk world's fleet, built from :class:`ControlParts`.

    Attributes:
        name: the name it is chosen by (a key of ``sim.spatial.control.CONTROLS``).
        free_cap_m: the path follower may compute a side step's free widths only this far, and
            exactly once a robot gets farther (inf: exact from the start).
        keeps_lists: ``Jobs`` must keep the state and the steering robots as Python lists.
    """

    name: str
    free_cap_m: float
    keeps_lists: bool

    def __init__(self, parts: ControlParts) -> None: ...

    def period(self, t: float) -> None:
        """One control period at simulated time ``t`` (s): poses in, motor commands out."""
