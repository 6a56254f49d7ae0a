"""The control period's one interface, its two implementations by name, and the choice between
them.

A control period reads the robots' poses, advances their tasks, steers them, caps their speeds
near robots and obstacles, limits the wheels and writes the motor commands. It exists twice with
the same formulas: over numpy arrays (:class:`ArrayControl`), and robot by robot in plain Python
(:class:`ScalarControl`), which is quicker for a small team because numpy's per-call overhead
dominates there. Both command the same wheels up to rounding, and each is bit-for-bit
reproducible on its own.
"""

from __future__ import annotations

from typing import Protocol

from sim.control.array import ArrayControl
from sim.control.scalar import ScalarControl

SMALL_TEAM = 24  # "auto": up to this many robots a control period runs per robot in Python


class Control(Protocol):
    """One control period of the pymunk world's fleet.

    An implementation is built with the world's collaborators as keyword arguments (``fleet``,
    ``schedule``, ``jobs``, ``motors``, ``follower``, ``controller``, ``arrive_tol_m``,
    ``reach_m``) and keeps no state of its own between periods beyond them.

    Attributes:
        name: the name it is chosen by (a key of :data:`CONTROLS`).
        free_cap_m: the path follower computes a side step's free widths only this far, and
            exactly once a robot gets farther (inf: exact from the start).
        keeps_lists: ``Jobs.refresh`` must keep the state and the steering robots as lists.
    """

    name: str
    free_cap_m: float
    keeps_lists: bool

    def period(self, t: float) -> None:
        """One control period at simulated time ``t`` (s): poses in, motor commands out."""


CONTROLS: dict[str, type[Control]] = {"array": ArrayControl, "scalar": ScalarControl}


def control_kind(control: str, n_robots: int) -> str:
    """The implementation ``control`` names for a team of ``n_robots``: ``"array"`` or
    ``"scalar"`` as given, or for ``"auto"`` scalar up to ``SMALL_TEAM`` robots, else array."""
    if control == "auto":
        return "scalar" if n_robots <= SMALL_TEAM else "array"
    if control not in CONTROLS:
        raise ValueError(f"control must be 'auto', 'array' or 'scalar'; got {control!r}")
    return control
