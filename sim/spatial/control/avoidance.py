"""ORCA in a control period: the same call from both implementations (``sim.spatial.law.orca``;
``sim.spatial.control.orca_small`` for the scalar period)."""

from __future__ import annotations

from functools import partial

import numpy as np

from sim.spatial.control.orca_small import avoid_small
from sim.spatial.control.protocol import ControlParts
from sim.spatial.law import orca as law
from sim.states import DRIVING


def steer_clear(parts: ControlParts, z, vel, h, pref, v_want, t: float, small: bool = False):
    """ORCA commands for the robots that steer themselves now (driving or yielding, not
    backing off blind).

    Args:
        parts: the world's state and collaborators.
        z, vel, h: (m,) positions, body velocities (x + iy) and unit headings.
        pref: (m,) preferred velocities (``sim.spatial.law.drive.preferred_velocity``), m/s.
        v_want: (m,) forward speeds the path following asks for, m/s.
        t: now, s.
        small: look at each robot in Python first (``sim.spatial.control.orca_small.avoid_small``,
            for the scalar control period of a small team); the same commands.

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
    p = parts.orca
    stood = None if p.meet_all else t - f.t_progress_s >= p.bias_stand_s
    call = avoid_small if small else law.avoid
    points = obstacle_points(parts)
    return call(*args, c.react_s, fol.to_obstacle, fol.lane_room, p, stood, points)


def obstacle_points(parts: ControlParts):
    """With ``wall_lines`` above 1, the obstacle points that give a robot its wall lines
    (``PathFollower.obstacle_points`` within the reach of a line at the top speed); else None
    (the nearest obstacle point only)."""
    if parts.orca.wall_lines == 1:
        return None
    points = parts.follower.obstacle_points
    return partial(points, reach_m=wall_reach_m(parts), count=parts.orca.wall_lines)


def wall_reach_m(parts: ControlParts) -> float:
    """How near an obstacle edge must be to give a robot a wall line (one could bind at the top
    speed; the compiled kernel's ``commands.walls`` computes the same); 0 with ``wall_lines``
    1 (the nearest obstacle point only)."""
    p, c = parts.orca, parts.controller
    if p.wall_lines == 1:
        return 0.0
    return c.radius_m + p.margin_m + p.wall_gap_m + c.v_max_mps * p.tau_obstacle_s


def wall_clear(parts: ControlParts, z, h, v, pref, orca, t: float):
    """Walls as ORCA lines (``sim.spatial.law.orca.steer_walls``) for the robots that steer
    themselves now and whose command robot-robot ORCA did not set (``orca``: its program had
    the obstacle lines already).

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
    v = np.asarray(v, dtype=float)
    rows = near_walls(fol, z, rows, v[rows], c.radius_m, parts.orca)
    if not len(rows):
        return None
    args = (c.radius_m, c.v_max_mps, fol.to_obstacle, fol.lane_room, parts.orca)
    return law.steer_walls(z, h, rows, v[rows], pref[rows], *args, obstacle_points(parts))


def near_walls(fol, z, rows, v, radius_m: float, p: law.OrcaLaw = law.DEFAULT):
    """Of robots ``rows`` (speed commands ``v``), those whose wall or lane lines could bind:
    the obstacle line only within radius + ``margin_m`` + ``wall_gap_m`` + |v| ``tau_obstacle_s``
    of an obstacle (a plan closes on it at |v| at most), the lane lines only within radius +
    ``lane_near_m`` (``p``: the law's settings, ``[spatial.orca]``). A robot's distance to the
    nearest obstacle is kept with where it was measured (on the follower: the obstacles stand
    still), so a robot that has not come closer than that reach by the way it has moved since is
    passed over without a look. The robots dropped could not have bound: the commands are the same
    as over all ``rows``."""
    m = len(z)
    cache = getattr(fol, "wall_seen_", None)
    if cache is None or len(cache[0]) != m:
        cache = fol.wall_seen_ = (np.zeros(m, dtype=complex), np.full(m, -np.inf))
    seen_z, seen_m = cache
    reach = np.abs(v) * p.tau_obstacle_s + (radius_m + p.margin_m + p.wall_gap_m)
    reach = np.maximum(reach, radius_m + p.lane_near_m) + 1e-6
    near = seen_m[rows] - np.abs(z[rows] - seen_z[rows]) < reach
    look = rows[near]
    if len(look):
        dist = np.abs(fol.to_obstacle(z[look]))
        seen_z[look], seen_m[look] = z[look], dist
        near[near] = dist < reach[near]
    return rows[near]
