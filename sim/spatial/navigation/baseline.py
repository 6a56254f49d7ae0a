"""numpy's baseline x86-64 arithmetic (``NPY_ENABLE_CPU_FEATURES=X86_V2``, the golden runs'),
compiled, for the kernels that must give numpy's answers bit for bit: a complex modulus as
numpy's baseline kernel computes it (``l * sqrt(1 + (s / l)^2)`` of the larger and smaller part,
nothing fused) and a clip to [0, 1] (``sim.spatial.plane``, ``sim.spatial.navigation.widths``).

numba inlines these into the kernels that call them and caches those kernels by their own
file only: after changing this module, clear the callers' caches (their ``__pycache__/*.nb*``)
or they keep the old arithmetic (a clean clone, as in CI, compiles afresh).
"""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True, nogil=True, inline="always")
def modulus(x: float, y: float) -> float:
    """|x + iy| as numpy's baseline kernel computes it."""
    re, im = abs(x), abs(y)
    big, small = max(re, im), min(re, im)
    if big == 0.0:
        return 0.0
    if math.isinf(big):
        return math.inf
    ratio = small / big
    return big * math.sqrt(1.0 + ratio * ratio)


@numba.njit(cache=True, nogil=True, inline="always")
def clip01(x: float) -> float:
    """``np.clip(x, 0.0, 1.0)`` as numpy computes it (a -0.0 comes out as 0.0)."""
    x = x if x > 0.0 else 0.0
    return x if x < 1.0 else 1.0
