"""Select the pymunk world's control path (scalar or array) for a golden run."""

from __future__ import annotations

import contextlib

import sim.physics


@contextlib.contextmanager
def forced_control(path: str | None):
    """Run the block with new pymunk worlds on the ``scalar`` or ``array`` control path.

    ``None`` leaves the choice to the team size.
    """
    old = sim.physics.SMALL_TEAM
    if path is not None:
        sim.physics.SMALL_TEAM = 10**6 if path == "scalar" else 0
    try:
        yield
    finally:
        sim.physics.SMALL_TEAM = old
