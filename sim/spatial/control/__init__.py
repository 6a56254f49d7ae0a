"""The control period of the pymunk world: compiled, and its numpy and plain-Python twins.

``protocol`` says what a control period is and what it works on; ``compiled`` is the one that
runs every team (the kernel in ``kernel``, numba, events in Python), ``array`` and ``scalar``
the numpy law over arrays and robot by robot, which stay as its reference; ``registry`` names
them and makes the ``"auto"`` choice. Collision avoidance for the numpy twins lives here too:
``orca_small`` (the law's first steps in plain Python for a small team) and ``avoidance`` (the
one call both make).

The drive law's formulas both periods share live one floor down, in ``sim.spatial.law.drive``: the
wheel limiter (``sim.spatial.motors``), the controller (``sim.spatial.controller``) and the site
queues (``sim.spatial.sites``) use them too, and this package imports those modules, so the formulas
cannot live here without an import cycle.
"""

from sim.spatial.control.array import ArrayControl
from sim.spatial.control.compiled import CompiledControl
from sim.spatial.control.protocol import Control, ControlParts
from sim.spatial.control.registry import CONTROLS, control_kind
from sim.spatial.control.scalar import ScalarControl

__all__ = [
    "CONTROLS",
    "ArrayControl",
    "CompiledControl",
    "Control",
    "ControlParts",
    "ScalarControl",
    "control_kind",
]
