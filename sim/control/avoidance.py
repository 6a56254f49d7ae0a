"""ORCA in a control period: the same call from both implementations (``sim.orca``)."""

from __future__ import annotations

import numpy as np

from sim.control.protocol import ControlParts
from sim.orca import avoid, steer_walls
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


def wall_clear(parts: ControlParts, z, h, v, pref, orca, t: float):
    """Walls as ORCA lines (``sim.orca.steer_walls``) for the robots that steer themselves now
    and whose command robot-robot ORCA did not set (``orca``: its program had the obstacle
    lines already).

    Args:
        z, h: (m,) positions and unit headings.
        v: (m,) speed commands so far (after the caps toward robots), m/s.
        pref: (m,) preferred velocities, m/s; orca: indices ORCA set (any collection), or None.

    Returns:
        None, or the robots whose command this sets and their (v, omega) commands.
    """
    f = parts.fleet
    steering = (f.state == DRIVING) | f.yielding
    if parts.schedule.n_backoff:
        steering &= ~(f.backoff_until_s > t)
    if orca is not None and len(orca):  # an index array (numpy period) or a set (scalar)
        done = orca if isinstance(orca, np.ndarray) else np.fromiter(orca, int, len(orca))
        steering[done] = False
    rows = steering.nonzero()[0]
    if not len(rows):
        return None
    c, fol = parts.controller, parts.follower
    args = (c.radius_m, c.v_max_mps, fol.to_obstacle, fol.lane_room)
    return steer_walls(z, h, rows, np.asarray(v, dtype=float)[rows], pref[rows], *args)
