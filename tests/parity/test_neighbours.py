"""The neighbour list against the all-pairs array (``DiffDriveController.proximity``): the same
caps, robots in the way and distances, bit for bit, as robots move."""

from __future__ import annotations

import itertools

import numpy as np

from sim.scenario import DriveSpec
from sim.spatial.controller import DiffDriveController


def test_neighbour_list_proximity_equals_the_dense_one_as_robots_move():
    """Above DENSE_MAX robots the pairs come from a Verlet list (KD-tree pairs within look_m
    plus a skin, reused until a robot has moved half the skin): period after period it gives
    the same caps, robots in the way and distances as the all-pairs array, bit for bit."""
    rng = np.random.default_rng(11)
    m = 160
    z = rng.uniform(0.0, 22.0, m) + 1j * rng.uniform(0.0, 22.0, m)
    th = rng.uniform(-np.pi, np.pi, m)
    listed = DiffDriveController(DriveSpec(), 0.1, dense_max=64)
    dense = DiffDriveController(DriveSpec(), 0.1, dense_max=10**6)
    lists, binding, blocked = [], 0, 0
    for _ in range(40):
        v = rng.uniform(-0.5, 1.5, m) * (rng.random(m) < 0.7)
        v_prev = rng.uniform(-0.5, 1.5, m) * (rng.random(m) < 0.7)
        hc = np.exp(-1j * th)
        ours = listed.proximity(z, hc, v, v_prev)
        lists.append(listed.verlet_z_)  # replaced when the list is rebuilt
        theirs = dense.proximity(z, hc, v, v_prev)
        for a, b in zip(ours[:3], theirs[:3], strict=True):
            np.testing.assert_array_equal(a, b)
        binding += int((np.abs(ours[0]) < np.abs(v)).sum())
        blocked += int((ours[1] >= 0).sum())
        z = z + rng.uniform(0.05, 0.2, m) * np.exp(1j * th)  # up to 0.2 m a period
        th = th + rng.uniform(-0.3, 0.3, m)
    rebuilt = sum(a is not b for a, b in itertools.pairwise(lists))
    assert 3 <= rebuilt < 30  # the list was rebuilt, and reused in between
    assert binding > 100 and blocked > 100  # caps bound and robots were in the way
