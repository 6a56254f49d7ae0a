"""Labels stamped on frames (``sim.render.text``): they never overlap."""

from __future__ import annotations

import itertools

import numpy as np


def test_labels_never_overlap_and_are_dropped_when_no_corner_is_free():
    from sim.render.text import place_labels

    sizes = [(20, 10)] * 6
    lone = place_labels(np.array([[100.0, 100.0]]), sizes[:1], 8.0)
    assert lone.tolist() == [[106.0, 94.0]]  # upper right of the robot, as labels always sat
    crowd = np.array([[100.0, 100.0]] * 6)  # six robots on one spot: four corners, two dropped
    anchors = place_labels(crowd, sizes, 8.0)
    placed = np.flatnonzero(np.isfinite(anchors[:, 0]))
    assert placed.tolist() == [0, 1, 2, 3]
    boxes = [(x, y - 10, x + 20, y) for x, y in anchors[placed]]
    for a, b in itertools.combinations(boxes, 2):
        assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]
