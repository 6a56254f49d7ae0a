"""The control period of the pymunk world, twice: over numpy arrays and robot by robot.

``protocol`` says what a control period is and what it works on, ``array`` and ``scalar`` are
its two implementations, ``registry`` names them and makes the ``"auto"`` choice. Collision
avoidance lives here too: ``orca`` (the law over numpy arrays), ``orca_small`` (its first steps
in plain Python for a small team) and ``avoidance`` (the one call both periods make).

The drive law's formulas both periods share live one floor down, in ``sim.spatial.law.drive``: the
wheel limiter (``sim.spatial.motors``), the controller (``sim.spatial.controller``) and the site
queues (``sim.spatial.sites``) use them too, and this package imports those modules, so the formulas
cannot live here without an import cycle.
"""

from sim.spatial.control.array import ArrayControl
from sim.spatial.control.protocol import Control, ControlParts
from sim.spatial.control.registry import CONTROLS, SMALL_TEAM, control_kind
from sim.spatial.control.scalar import ScalarControl

__all__ = [
    "CONTROLS",
    "SMALL_TEAM",
    "ArrayControl",
    "Control",
    "ControlParts",
    "ScalarControl",
    "control_kind",
]
