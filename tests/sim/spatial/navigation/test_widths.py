"""The compiled free widths beside a segment (``sim.spatial.navigation.widths``) are the plain
Python ones bit for bit: on the bundled arenas and a map, for random segments, segments from
and to obstacle corners, along edges and of zero length, with all obstacles and with the ones
near the segment."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scenarios.loader import load_scenario
from sim.spatial.navigation.paths import PathFollower, _to_segment

TB3 = Path(__file__).parents[3] / "scenarios" / "maps" / "tb3_sandbox.toml"


def python_sides(fol: PathFollower, a: complex, b: complex, owners) -> tuple[float, float]:
    """``PathFollower._sides`` as written in plain Python (the reference)."""
    length = abs(b - a)
    unit_c = (b - a).conjugate() / length if length > 1e-12 else 1.0
    left = right = np.inf
    for k in owners:
        verts, edges = fol.owners_[k]
        dist = min(_to_segment(p, a, b) for p in verts)
        for e0, e1 in edges:
            dist = min(dist, _to_segment(a, e0, e1), _to_segment(b, e0, e1))
        side = [((p - a) * unit_c).imag for p in verts]
        if max(side) > -1e-9:
            left = min(left, dist)
        if min(side) < 1e-9:
            right = min(right, dist)
    return left, right


@pytest.mark.parametrize("scenario", ["paper_spatial", "warehouse", "depot", str(TB3)])
def test_compiled_widths_are_pythons_bit_for_bit(scenario):
    sp = load_scenario(scenario).spatial
    fol = PathFollower(1, 1.5, sp.obstacles, sp.drive.radius_m, cap_m=2.0)
    rng = np.random.default_rng(2)
    n = 300
    a = rng.uniform(0, sp.width_m, n) + 1j * rng.uniform(0, sp.height_m, n)
    b = a + rng.normal(0, 3.0, n) + 1j * rng.normal(0, 3.0, n)
    corners = fol.verts_[rng.integers(0, len(fol.verts_), n)]
    b[: n // 4] = corners[: n // 4]  # to a corner
    a[n // 4 : n // 2] = corners[n // 4 : n // 2]  # from a corner ...
    b[n // 4 : n // 2] = fol.edge1_[rng.integers(0, len(fol.edge1_), n // 4)]  # ... to one
    b[n // 2 : n // 2 + 20] = a[n // 2 : n // 2 + 20]  # zero length
    checked = finite = 0
    for p, q in zip(a.tolist(), b.tolist(), strict=True):
        near = fol._near_cap(p, q)
        for owners in (range(fol.n_owner_), near):
            want = python_sides(fol, p, q, owners)
            got = fol._sides(p, q, None if isinstance(owners, range) else owners)
            assert (
                np.array(got).view(np.uint64).tolist() == np.array(want).view(np.uint64).tolist()
            ), (p, q)
            checked += 1
            finite += np.isfinite(want).sum()
    assert checked == 2 * n and finite > n
