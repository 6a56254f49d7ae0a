"""Select the pymunk world's control path (scalar or array) for a golden run."""

from __future__ import annotations

import contextlib
import functools

import learning.assembly as assembly
import sim


@contextlib.contextmanager
def forced_control(path: str | None):
    """Run the block with new pymunk worlds on the ``scalar`` or ``array`` control path.

    The runs build their world with ``sim.make_world`` (in ``learning.assembly``); inside the
    block that call passes
    ``control=path`` to the world. ``None`` leaves the choice to the team size.
    """
    if path is None:
        yield
        return
    old = assembly.make_world
    assembly.make_world = functools.partial(sim.make_world, control=path)
    try:
        yield
    finally:
        assembly.make_world = old
