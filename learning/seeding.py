"""The seed split of a run: one integer seed, three independent generators.

Following Gymnasium, a run's integer seed becomes ``np.random.SeedSequence(seed)``, spawned into
three generators: the task stream, the world and the allocator (its exploration). The stream
depends on the seed only, so every allocator and cost model compared on a seed sees the very
same tasks. Every caller that turns a seed into generators goes through :func:`run_generators`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class RunGenerators(NamedTuple):
    """The generators of one run, each from its own child of ``SeedSequence(seed)``."""

    stream: np.random.Generator
    world: np.random.Generator
    allocator: np.random.Generator


def run_generators(seed: int) -> RunGenerators:
    """Stream, world and allocator generators of the run seeded ``seed``."""
    stream_ss, world_ss, allocator_ss = np.random.SeedSequence(seed).spawn(3)
    return RunGenerators(
        np.random.default_rng(stream_ss),
        np.random.default_rng(world_ss),
        np.random.default_rng(allocator_ss),
    )
