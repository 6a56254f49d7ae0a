"""ORCA's commands for one robot, compiled: the velocity, the turn and the forward speed.

The rules are ``sim.spatial.law.orca``'s (where they are explained), for one robot at a time:
:func:`robot_command` is ``steer_rows`` (robot half-planes, then the wall and lane lines, the
right-hand bias), :func:`wall_command` ``steer_walls`` (the wall and lane lines alone), and
both end in :func:`command` (the velocity u from :func:`linprog.nearest_velocity`, the turn
toward it, the forward speed along the heading from :func:`forward_speed`). Lines are kept with
the walls first, so that the velocity program holds them hard where the robots' lines leave
nothing (``linprog``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim.spatial.control.kernel.halfplanes import BIG, agent_line, obstacle_line, wall_lines
from sim.spatial.control.kernel.linprog import nearest_velocity

WALL_LINES = 3  # the obstacle line and the two lane lines


@njit(cache=True)
def along(u, n):
    """n . u, as the numpy law computes it: Re(u conj(n))."""
    return (u * n.conjugate()).real


@njit(cache=True)
def forward_speed(normal, offset, count, n_wall, h, v_want, v_max, law):
    """The speed v along heading h nearest ``v_want`` with v h in every line (less the slack on
    lines the heading runs nearly along: ``wall_slack_mps`` on the first ``n_wall``,
    ``robot_slack_mps`` on the others) and -``back_share`` v_max <= v <= v_max; where none is,
    the middle of what the lines leave (``sim.spatial.law.orca.forward_speed``)."""
    lo, hi = -np.inf, np.inf
    for j in range(count):
        a = (h * normal[j].conjugate()).real  # a v >= c
        slack = law.wall_slack_mps if j < n_wall else law.robot_slack_mps
        c = offset[j] - (slack if abs(a) < law.slack_shallow else 0.0)
        if a > 1e-9:
            lo = max(lo, c / a)
        elif a < -1e-9:
            hi = min(hi, c / a)
    back = -law.back_share * v_max
    lo, hi = max(lo, back), min(hi, v_max)
    if lo <= hi:
        return min(max(v_want, lo), hi)
    return min(max(0.5 * (lo + hi), back), v_max)


@njit(cache=True)
def command(normal, offset, count, n_wall, pref, h, v_max, law, proj_n, proj_c):
    """(v, omega) of a robot with heading h under the lines ``[:count]`` (walls first, hard):
    the velocity u (:func:`linprog.nearest_velocity`), the turn toward it and the forward speed
    along the heading that keeps every line (``sim.spatial.law.orca.command``)."""
    u = nearest_velocity(normal, offset, count, n_wall, pref, v_max, proj_n, proj_c)
    local = u * h.conjugate()
    err = math.atan2(local.imag, local.real)
    align = (math.cos(err) - law.cos_turn) / (1.0 - law.cos_turn)
    align = 0.0 if align < 0.0 else (1.0 if align > 1.0 else align)
    v = forward_speed(normal, offset, count, n_wall, h, abs(u) * align, v_max, law)
    return v, err * law.heading_gain


@njit(cache=True)
def add_walls(ob, points, n_points, side_m, left, free0, free1, radius_m, law, normal, offset):
    """The wall and lane lines of a robot (:func:`halfplanes.wall_lines`) that can bind, into
    the start of ``normal``, ``offset``; their count. The obstacle lines are those of
    ``points[:n_points]`` (``obstacles.obstacle_points``), or with ``n_points`` < 0 the one of
    ``ob``, the nearest obstacle point (``sim.spatial.law.orca.wall_lines``)."""
    wall_lines(ob, side_m, left, free0, free1, radius_m, law, normal, offset)
    if n_points < 0:
        n = 0
        for j in range(WALL_LINES):
            if offset[j] > -BIG / 2:
                normal[n], offset[n] = normal[j], offset[j]
                n += 1
        return n
    lanes_n, lanes_c = (normal[1], normal[2]), (offset[1], offset[2])
    r_air, inv = radius_m + law.margin_m + law.wall_gap_m, 1.0 / law.tau_obstacle_s
    for s in range(n_points):
        normal[s], offset[s] = obstacle_line(points[s], r_air, inv)
    n = n_points
    for s in range(2):
        if lanes_c[s] > -BIG / 2:
            normal[n], offset[n] = lanes_n[s], lanes_c[s]
            n += 1
    return n


@njit(cache=True)
def robot_lines(i, z, vel, steering, near, count, radius_m, react_s, law, normal, offset, start):
    """Robot i's half-planes against its neighbours ``near[:count]`` into ``normal``,
    ``offset`` from ``start`` on (a share of one half against a robot that steers itself, all
    of it against one that stands)."""
    combined = 2.0 * (radius_m + law.margin_m)
    inv_tau, inv_dt = 1.0 / law.tau_s, 1.0 / react_s
    for s in range(count):
        k = near[s]
        share = 0.5 if steering[k] else 1.0
        n, c = agent_line(z[k] - z[i], vel[i] - vel[k], vel[i], share, combined, inv_tau, inv_dt)
        normal[start + s], offset[start + s] = n, c


@njit(cache=True)
def binds(normal, offset, start, count, plan):
    """True if the velocity ``plan`` breaks one of the lines ``[start:count]`` by more than
    1e-9 (the numpy law's test)."""
    worst = -np.inf
    for j in range(start, count):
        worst = max(worst, offset[j] - along(plan, normal[j]))
    return worst > 1e-9


@njit(cache=True)
def meeting(i, z, vel, pref_i, near, count, cos_meet):
    """True if a neighbour ``near[:count]`` of robot i lies within the meeting angle (cosine
    ``cos_meet``) of i's preferred velocity relative to that neighbour's velocity
    (``sim.spatial.law.orca.meeting``)."""
    for s in range(count):
        k = near[s]
        rel, d = z[k] - z[i], pref_i - vel[k]
        if (d * rel.conjugate()).real > cos_meet * (abs(d) * abs(rel)):
            return True
    return False


@njit(cache=True)
def with_bias(pref, ob, radius_m, law):
    """The preferred velocity turned right by the bias where the body has more than
    ``bias_room_m`` of room to the nearest obstacle (``sim.spatial.law.orca.steer_rows``)."""
    bias = law.keep_right if abs(ob) - radius_m > law.bias_room_m else 1.0 + 0j
    return pref * bias
