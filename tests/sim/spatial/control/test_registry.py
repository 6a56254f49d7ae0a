"""Which control period a world runs (``sim.spatial.control``): by name, or by team size."""

from __future__ import annotations

import pytest

from sim.spatial.control import (
    CONTROLS,
    ArrayControl,
    CompiledControl,
    ScalarControl,
    control_kind,
)
from sim.spatial.world import PymunkWorld
from tests.worlds import crowd_scenario


def test_control_is_chosen_by_name_or_by_team_size():
    assert control_kind("auto", 3) == control_kind("auto", 3000) == "compiled"
    assert control_kind("array", 3) == "array" and control_kind("scalar", 300) == "scalar"
    assert CONTROLS == {"array": ArrayControl, "scalar": ScalarControl, "compiled": CompiledControl}
    with pytest.raises(ValueError, match="'auto', 'array', 'scalar' or 'compiled'"):
        control_kind("vector", 3)
    world = PymunkWorld(crowd_scenario())
    assert world.control_kind == "compiled" and isinstance(world.control, CompiledControl)
    assert PymunkWorld(crowd_scenario(), control="array").control.name == "array"
