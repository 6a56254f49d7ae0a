"""The control period of the pymunk world, twice: over numpy arrays and robot by robot.

``interface`` holds the :class:`Control` protocol, the registry of implementations by name and
the ``"auto"`` choice; ``array`` and ``scalar`` are the two implementations.
"""

from sim.control.array import ArrayControl
from sim.control.interface import CONTROLS, SMALL_TEAM, Control, control_kind
from sim.control.scalar import ScalarControl

__all__ = ["CONTROLS", "SMALL_TEAM", "ArrayControl", "Control", "ScalarControl", "control_kind"]
