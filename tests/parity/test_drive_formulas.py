"""The shared formulas of ``sim.spatial.law.drive`` give the same numbers on floats (``math``,
the scalar control period) as on arrays (numpy, the array control period), bit for bit. The
numbers worked by hand are in ``tests/sim/spatial/law/test_drive.py``."""

from __future__ import annotations

import math

import numpy as np

from sim.spatial.law import drive as law


def test_shared_formulas_give_the_same_numbers_on_floats_and_arrays():
    """Real-valued formulas: float by float with ``math`` equals elementwise with numpy, bit for
    bit (each case: the formula, its array arguments, then its constants for floats and for
    arrays)."""
    rng = np.random.default_rng(2)
    a, b, c, d = (rng.uniform(-2.0, 2.0, 2000) for _ in range(4))
    pos = rng.uniform(0.01, 3.0, 2000)
    cases = [
        (law.steer_speeds, (a, pos, pos), (3.0, -1.5, 1.2, math.sqrt), (3.0, -1.5, 1.2, np.sqrt)),
        (law.stopping_time_s, (a,), (0.1, 0.4), (0.1, 0.4)),
        (
            law.approach_cap_mps,
            (pos, pos),
            (3.0, 0.2, 0.04, math.sqrt, 0.15),
            (3.0, 0.2, 0.04, np.sqrt, 0.15),
        ),
        (law.pair_share_m, (a, b, c), (), ()),
        (law.rim_speed_mps, (a, b), (), ()),
        (law.twist_from_rims, (a, b, c, d), (), ()),
        (law.on_arc, (a, b * 1e-4), (), ()),
        (law.goes_our_way, (a, b), (math.cos, 0.5), (np.cos, 0.5)),
    ]
    for fn, arrays, float_consts, array_consts in cases:
        rows = zip(*(x.tolist() for x in arrays), strict=True)
        ours = np.array([fn(*row, *float_consts) for row in rows])
        theirs = np.array(fn(*arrays, *array_consts))
        np.testing.assert_array_equal(ours.T, theirs, err_msg=fn.__name__)
    assert law.next_check_s(2.0, -1.0, 3.0) == 2.0 and law.next_check_s(2.0, 3.0, 3.0) == 3.0
