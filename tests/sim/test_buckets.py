"""BoxBuckets: the boxes a query may touch, never fewer than a full loop finds."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.buckets import MAX_CELLS, BoxBuckets, typical_size

coord = st.floats(-20.0, 40.0, allow_nan=False)
box = st.tuples(coord, coord, st.floats(0.0, 6.0), st.floats(0.0, 6.0)).map(
    lambda b: (b[0], b[1], b[0] + b[2], b[1] + b[3])
)


def meets(b, x0, y0, x1, y1) -> bool:
    return b[0] <= x1 and x0 <= b[2] and b[1] <= y1 and y0 <= b[3]


@settings(max_examples=200, deadline=None)
@given(st.lists(box, min_size=1, max_size=40), st.lists(box, min_size=1, max_size=10))
def test_near_and_at_return_every_box_that_meets_the_query_in_index_order(boxes, queries):
    buckets = BoxBuckets(boxes, typical_size(boxes))
    for q in queries:
        found = buckets.near(*q)
        assert found == sorted(set(found))
        assert {k for k, b in enumerate(boxes) if meets(b, *q)} <= set(found)
        x, y = q[0], q[1]
        at = buckets.at(x, y)
        assert at == sorted(set(at))
        assert {k for k, b in enumerate(boxes) if meets(b, x, y, x, y)} <= set(at)


def test_a_small_query_in_a_large_field_looks_at_few_boxes():
    """100 boxes on a grid: a 1 m query sees its neighbours, not all; a huge one gets all."""
    rng = np.random.default_rng(0)
    corners = rng.uniform(0.0, 100.0, size=(100, 2))
    boxes = [(x, y, x + 2.0, y + 2.0) for x, y in corners.tolist()]
    buckets = BoxBuckets(boxes, typical_size(boxes))
    assert typical_size(boxes) == 2.0
    sizes = [len(buckets.near(x, y, x + 1.0, y + 1.0)) for x, y in corners.tolist()]
    assert max(sizes) < 10 and min(sizes) >= 1  # each query holds its own box's corner
    assert buckets.near(0.0, 0.0, 2.0 * MAX_CELLS, 2.0 * MAX_CELLS) == list(range(100))
