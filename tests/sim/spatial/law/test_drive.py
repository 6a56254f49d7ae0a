"""The drive law's pure formulas (``sim.spatial.law.drive``) on numbers worked out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.spatial.law import drive as law


def test_the_law_s_formulas_give_the_numbers_worked_by_hand():
    """Each formula of ``sim.spatial.law.drive`` on numbers worked out by hand (the parity test
    above runs them on random numbers but cannot see a wrong formula both sides share)."""
    assert law.steer_speeds(1.0, 2.0, 0.25, 3.0, -1.5, 1.2, math.sqrt) == (1.5, math.sqrt(2.65))
    # ORCA's preferred velocity: toward the aim, at the speed that still brakes within the gap
    pv = law.preferred_velocity(3 + 4j, 0.5, 0.0, 1.0, 1.5, math.sqrt, min)  # sqrt(0.5 * 2)
    assert abs(pv - (0.6 + 0.8j)) < 1e-12
    pv = law.preferred_velocity(3 + 4j, 2.0, 0.25, 0.5, 3.0, math.sqrt, min)  # sqrt(2.25)
    assert abs(pv - (0.9 + 1.2j)) < 1e-12
    pv = law.preferred_velocity(-6.0, 9.0, 0.0, 1.0, 1.5, math.sqrt, min)  # capped at the top
    assert abs(pv - (-1.5)) < 1e-12
    assert law.preferred_velocity(0j, 0.0, 0.0, 1.0, 1.5, math.sqrt, min) == 0
    tiny = law.preferred_velocity(1e-13 + 0j, 1e-13, 0.0, 1.0, 1.5, math.sqrt, min)
    assert tiny.real >= 0.0  # at its aim point a robot never prefers to move away from it
    assert law.stopping_time_s(-0.8, 0.1, 0.25) == pytest.approx(0.3, abs=1e-15)
    cap, creep = law.approach_cap_mps(0.5, 0.5, 3.0, 0.2, 0.04, math.sqrt, 0.15)
    assert cap == pytest.approx(math.sqrt(3.04) - 0.2, abs=1e-15) and creep == pytest.approx(0.3)
    assert law.pair_share_m(2.0, 0.5, 0.3) == (1.5, 0.9)
    assert law.rim_speed_mps(-0.4, 0.3) == pytest.approx(0.7, abs=1e-15)
    assert law.twist_from_rims(0.2, -0.1, 1.0, 0.5) == pytest.approx((1.05, 0.65), abs=1e-15)
    assert not law.on_arc(1.0, 1e-4) and law.on_arc(0.99, 1e-4)  # radius 1e4 m is straight
    # within 60 degrees of our heading goes our way; the difference counts, not the sum
    assert law.goes_our_way(1.0, 0.5, math.cos, 0.5)
    assert not law.goes_our_way(1.0, -0.5, math.cos, 0.5)


def test_control_body_sits_at_the_centre_of_the_arc():
    """On an arc the control body stands still at z + i R h; straight it moves at v h."""
    z, h = 2.0 + 3.0j, np.exp(0.7j)
    v, w = 1.2, 0.6
    centre, vel = law.control_body(z, h, v, w, v / w)
    assert abs(centre - (z + 2.0 * 1j * h)) < 1e-12 and abs(vel) < 1e-12
    centre, vel = law.control_body(z, h, v, 0.0, 0.0)
    assert centre == z and vel == v * h
    zs, hs = np.array([z, z]), np.array([h, h])
    arr_centre, arr_vel = law.control_body(
        zs, hs, np.array([v, v]), np.array([w, 0.0]), np.array([v / w, 0.0])
    )
    np.testing.assert_allclose(arr_centre, [z + 2.0 * 1j * h, z], rtol=0, atol=1e-12)
    np.testing.assert_allclose(arr_vel, [0.0, v * h], rtol=0, atol=1e-12)
