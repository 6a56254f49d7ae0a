"""The compiled free widths beside a segment (``sim.spatial.navigation.widths``) are the plain
Python ones bit for bit: on the bundled arenas and a map, for random segments, segments from
and to obstacle corners, along edges and of zero length, with all obstacles and with the ones
near the segment. The widths of many segments at once (``free_widths``, ``PathFollower._free``)
are the numpy arrays' below bit for bit with numpy's baseline kernels (the golden runs'
numerics, checked in a child Python with ``NPY_ENABLE_CPU_FEATURES=X86_V2``) and within
rounding with the kernels this CPU dispatches."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scenarios.loader import load_scenario
from sim.spatial.navigation.paths import SCALAR_FREE_MAX, PathFollower, _to_segment
from tests.golden.cases import in_baseline_child

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


def numpy_to_segments(p: np.ndarray, s0: np.ndarray, s1: np.ndarray) -> np.ndarray:
    """Distance from points p to segments s0 -> s1 (complex, broadcast together)."""
    d = s1 - s0
    t = ((p - s0) * d.conj()).real / np.maximum((d * d.conj()).real, 1e-24)
    return np.abs(p - s0 - np.minimum(np.maximum(t, 0.0), 1.0) * d)


def numpy_free(fol: PathFollower, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``PathFollower._free``'s widths as numpy arrays compute them (the reference)."""
    e0, e1, v = fol.edge0_, fol.edge1_, fol.verts_
    ends = np.minimum(numpy_to_segments(a[:, None], e0, e1), numpy_to_segments(b[:, None], e0, e1))
    dist = np.minimum(
        np.minimum.reduceat(ends, fol.edge_start_, axis=1),
        np.minimum.reduceat(numpy_to_segments(v, a[:, None], b[:, None]), fol.vert_start_, axis=1),
    )
    dist -= fol.radius_m
    unit = (b - a) / np.maximum(np.abs(b - a), 1e-12)
    side = ((v - a[:, None]) * unit.conj()[:, None]).imag
    left = np.maximum.reduceat(side > -1e-9, fol.vert_start_, axis=1)
    right = np.maximum.reduceat(side < 1e-9, fol.vert_start_, axis=1)
    out = np.full((len(a), 2), np.inf)
    out[:, 0] = np.where(left, dist, np.inf).min(axis=1)
    out[:, 1] = np.where(right, dist, np.inf).min(axis=1)
    return np.maximum(out, 0.0)


def many_cases(scenario: str, seed: int) -> tuple[PathFollower, np.ndarray, np.ndarray]:
    """Random segments in the arena, to and from obstacle corners, and of no length."""
    sp = load_scenario(scenario).spatial
    fol = PathFollower(1, 1.5, sp.obstacles, sp.drive.radius_m, cap_m=2.0)
    rng = np.random.default_rng(seed)
    n = 300
    a = rng.uniform(0, sp.width_m, n) + 1j * rng.uniform(0, sp.height_m, n)
    b = a + rng.normal(0, 3.0, n) + 1j * rng.normal(0, 3.0, n)
    corners = fol.verts_[rng.integers(0, len(fol.verts_), n)]
    b[:100] = corners[:100]  # to a corner
    a[100:200] = corners[100:200]  # from one
    b[200:220] = a[200:220]  # no length
    return fol, a, b


MANY = [("paper_spatial", 0), ("warehouse", 1), ("depot", 2), (str(TB3), 3)]


def many_mismatches() -> list[list[int]]:
    """[segments checked, widths not numpy's bit for bit] per case of ``MANY``."""
    out = []
    for scenario, seed in MANY:
        fol, a, b = many_cases(scenario, seed)
        got, want = fol._free(a, b), numpy_free(fol, a, b)
        out.append([len(a), int((got.view(np.uint64) != want.view(np.uint64)).sum())])
    return out


@pytest.mark.parametrize("scenario, seed", MANY)
def test_widths_of_many_segments_are_numpys_within_rounding(scenario, seed):
    """With this CPU's numpy kernels (fused or not): within 1e-12 m, 0 where numpy has 0 and
    inf where it has inf; the cases take the compiled pass and reach both."""
    fol, a, b = many_cases(scenario, seed)
    assert len(a) * len(fol.edge0_) > SCALAR_FREE_MAX  # not the plain-Python pass
    got, want = fol._free(a, b), numpy_free(fol, a, b)
    assert got.shape == want.shape == (len(a), 2)
    assert np.array_equal(got == 0.0, want == 0.0) and np.array_equal(np.isinf(got), np.isinf(want))
    finite = np.isfinite(want)
    assert np.abs(got[finite] - want[finite]).max() < 1e-12
    assert (want == 0.0).any() and finite.mean() > 0.5


def test_widths_of_many_segments_are_numpys_bit_for_bit_with_baseline_kernels():
    """In a child Python with numpy's baseline kernels (what the golden runs use), every
    width is numpy's to the last bit."""
    tallies = in_baseline_child(__file__, "ns['many_mismatches']()")
    assert len(tallies) == len(MANY)
    for (scenario, _), (checked, differ) in zip(MANY, tallies, strict=True):
        assert checked == 300 and differ == 0, (scenario, differ)
