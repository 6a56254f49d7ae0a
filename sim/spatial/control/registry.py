"""The control periods by name, and the choice ``"auto"`` makes between them."""

from __future__ import annotations

from sim.spatial.control.array import ArrayControl
from sim.spatial.control.protocol import Control
from sim.spatial.control.scalar import ScalarControl

SMALL_TEAM = 24  # "auto": up to this many robots a control period runs per robot in Python

CONTROLS: dict[str, type[Control]] = {"array": ArrayControl, "scalar": ScalarControl}


def control_kind(control: str, n_robots: int) -> str:
    """The implementation ``control`` names for a team of ``n_robots``: ``"array"`` or
    ``"scalar"`` as given, or for ``"auto"`` scalar up to ``SMALL_TEAM`` robots, else array."""
    if control == "auto":
        return "scalar" if n_robots <= SMALL_TEAM else "array"
    if control not in CONTROLS:
        raise ValueError(f"control must be 'auto', 'array' or 'scalar'; got {control!r}")
    return control
