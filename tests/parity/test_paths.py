"""The path follower's fast computations against the exact ones
(``sim.spatial.navigation.paths.PathFollower``): the nearest obstacle point in Python against the
array version, and free widths capped and refined on demand against the exact widths."""

from __future__ import annotations

import numpy as np

from sim.scenario import DriveSpec
from sim.spatial.navigation.paths import PathFollower

R = DriveSpec().radius_m


def test_nearest_obstacle_point_in_python_equals_the_array_version():
    """``to_obstacle_one`` (bounding boxes skipped when no nearer) finds the same point."""
    box = ((5.0, 1.0), (7.0, 1.0), (7.0, 3.0), (5.0, 3.0))
    tri = ((12.0, 4.0), (16.0, 4.5), (14.0, 8.0))
    walls = [((0, 0), (20, 0)), ((20, 0), (20, 10)), ((20, 10), (0, 10)), ((0, 10), (0, 0))]
    f = PathFollower(1, 1.5, [box, tri, *walls], R)
    z = np.random.default_rng(3).uniform((0, 0), (20, 10), size=(500, 2)) @ np.array([1, 1j])
    ours = np.array([f.to_obstacle_one(p) for p in z.tolist()])
    np.testing.assert_allclose(ours, f.to_obstacle(z), rtol=0, atol=1e-12)


def test_free_widths_capped_and_refined_on_demand_steer_as_the_exact_ones():
    """Side-step widths computed only as far as cap_m (large teams) and exactly once a robot
    is farther off: targets and drifting decide as with the exact widths, wherever the robot."""
    boxes = [
        ((x, y), (x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0))
        for x, y in [(3.0, 2.0), (8.0, 6.0), (14.0, 3.0), (16.0, 7.5)]
    ]
    walls = [((0, 0), (20, 0)), ((20, 0), (20, 10)), ((20, 10), (0, 10)), ((0, 10), (0, 0))]
    m = 400
    exact = PathFollower(m, 1.5, [*boxes, *walls], R)
    capped = PathFollower(m, 1.5, [*boxes, *walls], R, cap_m=1.0)
    rng = np.random.default_rng(4)
    a = rng.uniform((1.0, 1.0), (19.0, 9.0), size=(m, 2))
    b = a + rng.uniform(-1.0, 1.0, size=(m, 2))  # side steps: about 1 m
    for j in range(m):
        for f in (exact, capped):
            f.set_path(j, np.array([a[j], b[j]]))
    flagged = capped.capped_m[:, 1].copy()
    assert flagged.sum() > 100  # many widths only known to be >= 1 m ...
    np.testing.assert_array_equal(
        capped.free_m[:, 1][~flagged], exact.free_m[:, 1][~flagged]
    )  # others exact
    assert (capped.free_m[:, 1][flagged] == 1.0).all() and (exact.free_m[:, 1][flagged] > 1.0).all()
    lateral = 1j * (b - a) @ np.array([1.0, 1j])
    lateral /= np.abs(lateral)
    z = (a + 0.5 * (b - a)) @ np.array([1.0, 1j]) + rng.uniform(-6.0, 6.0, m) * lateral
    h = np.exp(1j * rng.uniform(-np.pi, np.pi, m))
    v = rng.uniform(-1.5, 1.5, m)
    ours, theirs = capped.targets(z), exact.targets(z)  # refines the capped widths it must
    for x, y in zip(ours, theirs, strict=True):
        np.testing.assert_array_equal(x, y)
    before = capped.capped_m[:, 1].sum()
    np.testing.assert_array_equal(
        capped.drifting(z, h, v, 0.1, 0.5), exact.drifting(z, h, v, 0.1, 0.5)
    )
    assert capped.capped_m[:, 1].sum() < before  # drifting made some more exact
    refined = flagged & ~capped.capped_m[:, 1]
    assert refined.sum() > 20  # robots far off the path made their widths exact
    np.testing.assert_array_equal(capped.free_m[:, 1][refined], exact.free_m[:, 1][refined])
    assert capped.capped_m[:, 1].sum() > 50  # ... and only theirs
