"""ORCA's half-planes of one robot, compiled: against a neighbour, a wall and a single lane.

A half-plane is a unit normal n and an offset c: the velocities u with n . u >= c are allowed
(``sim.spatial.law.orca`` holds the same lines over numpy arrays and explains them). The
arithmetic is the numpy functions', written for one robot: :func:`agent_line` is
``half_planes`` (RVO2's ``Agent::computeNewVelocity`` for agents), :func:`obstacle_line`
``obstacle_plane`` and :func:`wall_lines` ``wall_lines``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

BIG = 1e9  # an offset of -BIG: a line that never binds (the numpy law's unused lines)


@njit(cache=True)
def agent_line(rel_p, rel_v, vel_i, share, combined_m, inv_tau, inv_dt):
    """The ORCA half-plane of robot i against one neighbour.

    Args:
        rel_p: neighbour position minus i's, m (complex); rel_v: i's velocity minus the
            neighbour's, m/s; vel_i: i's velocity, m/s.
        share: i's share of the avoidance (0.5 reciprocal, 1 against a standing robot).
        combined_m: sum of the two radii, m; inv_tau: 1 / horizon; inv_dt: 1 / collision period.

    Returns:
        The unit normal n (complex) and offset c of {u : n . u >= c}.
    """
    dist2 = (rel_p * rel_p.conjugate()).real
    r2 = combined_m * combined_m
    w = rel_v - rel_p * inv_tau  # from the centre of the cut-off circle to the relative velocity
    w2 = (w * w.conjugate()).real
    dot1 = (w * rel_p.conjugate()).real
    apart = dist2 > r2
    cutoff = apart and dot1 < 0.0 and dot1 * dot1 > r2 * w2
    if cutoff or not apart:  # the cut-off circle (of the collision period when touching)
        if not apart:
            w = rel_v - rel_p * inv_dt
            w2 = (w * w.conjugate()).real
        w_len = math.sqrt(max(w2, 1e-18))
        unit_w = w / w_len
        u = (combined_m * (inv_tau if apart else inv_dt) - w_len) * unit_w
        direction = -1j * unit_w
    else:  # a leg of the cone: left when the relative velocity passes on the left of rel_p
        leg = math.sqrt(max(dist2 - r2, 0.0))
        safe2 = max(dist2, 1e-18)
        if (rel_p.conjugate() * w).imag > 0.0:
            direction = rel_p * (leg + 1j * combined_m) / safe2
        else:
            direction = -(rel_p * (leg - 1j * combined_m)) / safe2
        u = (rel_v * direction.conjugate()).real * direction - rel_v
    point = vel_i + share * u
    normal = 1j * direction  # allowed side: left of the direction
    return normal, (point * normal.conjugate()).real


@njit(cache=True)
def obstacle_line(to_obstacle, radius_m, inv_tau):
    """The half-plane that keeps a robot of ``radius_m`` off the obstacle point ``to_obstacle``
    (x + iy from its centre) for ``1 / inv_tau`` s; offset -BIG without an obstacle."""
    dist = abs(to_obstacle)
    if not np.isfinite(dist):
        return 1.0 + 0j, -BIG
    return -to_obstacle / max(dist, 1e-12), -(dist - radius_m) * inv_tau


@njit(cache=True)
def wall_lines(ob, side_m, left, free0, free1, radius_m, law, normal, offset):
    """A robot's obstacle and lane half-planes into ``normal[:3]``, ``offset[:3]``: the nearest
    obstacle point ``ob`` (x + iy from its centre; horizon ``tau_obstacle_s``, air
    ``wall_gap_m``) and the two sides of a single lane (``PathFollower.lane_room``): where the
    free width of its path segment is below ``lane_narrow_m`` and an obstacle within
    ``lane_near_m`` of the body, keep the centre inside it, less ``lane_air_m``. Unused lines
    get offset -BIG.

    Args:
        side_m: minus the robot's offset to the left of its segment, m; left: the unit vector
            to the left of the segment (0 without one); free0, free1: minus the free width to
            the left, the free width to the right (``PathFollower.free_``), m.
    """
    inv = 1.0 / law.tau_obstacle_s
    normal[0], offset[0] = obstacle_line(ob, radius_m + law.margin_m + law.wall_gap_m, inv)
    room_l, room_r = side_m - free0, free1 - side_m
    real = abs(left) > 0.5 and room_l + room_r < law.lane_narrow_m
    real = real and abs(ob) < radius_m + law.lane_near_m  # between walls here, not past them
    normal[1], normal[2] = (-left, left) if real else (1.0 + 0j, 1.0 + 0j)
    rooms = (room_l - law.lane_air_m, room_r - law.lane_air_m)
    for s in range(2):
        ok = real and np.isfinite(rooms[s])
        offset[1 + s] = -rooms[s] / law.tau_obstacle_s if ok else -BIG
