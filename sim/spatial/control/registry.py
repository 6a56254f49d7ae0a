"""The control periods by name, and the choice ``"auto"`` makes: the compiled one, for every
team size (``array`` and ``scalar``, its numpy twins, stay as its reference in the tests)."""

from __future__ import annotations

from sim.spatial.control.array import ArrayControl
from sim.spatial.control.compiled import CompiledControl
from sim.spatial.control.protocol import Control
from sim.spatial.control.scalar import ScalarControl

CONTROLS: dict[str, type[Control]] = {
    "array": ArrayControl,
    "scalar": ScalarControl,
    "compiled": CompiledControl,
}


def control_kind(control: str, n_robots: int) -> str:
    """The implementation ``control`` names for a team of ``n_robots``: ``"array"``,
    ``"scalar"`` or ``"compiled"`` as given, and for ``"auto"`` the compiled one, whatever the
    team's size."""
    if control == "auto":
        return "compiled"
    if control not in CONTROLS:
        raise ValueError(
            f"control must be 'auto', 'array', 'scalar' or 'compiled'; got {control!r}"
        )
    return control
