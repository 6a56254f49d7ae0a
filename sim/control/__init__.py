"""The control period of the pymunk world, twice: over numpy arrays and robot by robot.

``protocol`` says what a control period is and what it works on, ``array`` and ``scalar`` are
its two implementations, ``registry`` names them and makes the ``"auto"`` choice. Collision
avoidance lives here too: ``orca`` (the law over numpy arrays), ``orca_small`` (its first steps
in plain Python for a small team) and ``avoidance`` (the one call both periods make).

The drive law's formulas both periods share live one floor down, in ``sim.drive_law``: the
wheel limiter (``sim.motors``), the controller (``sim.drive``) and the site queues
(``sim.sites``) use them too, and this package imports those modules, so the formulas cannot
live here without an import cycle.
"""

from sim.control.array import ArrayControl
from sim.control.protocol import Control, ControlParts
from sim.control.registry import CONTROLS, SMALL_TEAM, control_kind
from sim.control.scalar import ScalarControl

__all__ = [
    "CONTROLS",
    "SMALL_TEAM",
    "ArrayControl",
    "Control",
    "ControlParts",
    "ScalarControl",
    "control_kind",
]
