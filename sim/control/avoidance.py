"""ORCA in a control period: the same call from both implementations (``sim.orca``)."""

from __future__ import annotations

from sim.control.protocol import ControlParts
from sim.orca import avoid
from sim.orca_small import avoid_small
from sim.recording import DRIVING


def steer_clear(parts: ControlParts, z, vel, h, pref, v_want, t: float, small: bool = False):
    """ORCA commands for the robots that steer themselves now (driving or yielding, not
    backing off blind).

    Args:
        parts: the world's state and collaborators.
        z, vel, h: (m,) positions, body velocities (x + iy) and unit headings.
        pref: (m,) preferred velocities (``sim.drive_law.preferred_velocity``), m/s.
        v_want: (m,) forward speeds the path following asks for, m/s.
        t: now, s.
        small: look at each robot in Python first (``sim.orca_small.avoid_small``, for the scalar
            control period of a small team); the same commands.

    Returns:
        None, or the robots whose plan ORCA replaces and their (v, omega) commands.
    """
    f, c = parts.fleet, parts.controller
    steering = (f.state == DRIVING) | f.yielding
    if parts.schedule.n_backoff:
        steering &= ~(f.backoff_until_s > t)
    rows = steering.nonzero()[0]
    if not len(rows):
        return None
    fol = parts.follower
    args = (z, vel, h, rows, pref[rows], v_want[rows], steering, c.radius_m, c.v_max_mps)
    return (avoid_small if small else avoid)(*args, c.react_s, fol.to_obstacle, fol.lane_room)
