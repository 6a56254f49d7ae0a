"""The first half of the compiled control period: poses in, each robot's wish out.

:func:`read_poses` turns the motors' batched read into positions, headings and velocities and
keeps the odometer; :func:`steer_all` advances every robot's path, steers it and keeps its
progress (``ArrayControl._steer`` without its events). What only Python can do (stop a yield,
restart a robot's tries, the stuck check, arrival, the end of work) is left to the caller,
which the flags this half writes tell when to act (``sim.spatial.control.compiled``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from sim.spatial.control.kernel.drive import aim, steer

DRIVING = 1  # sim.states.DRIVING (the kernel reads the state as int8 codes)
IDLE = 0  # sim.states.IDLE


class Fleet(NamedTuple):
    """The fleet state the kernel reads and writes (``sim.spatial.fleet.FleetState``'s arrays
    of the same names, handed over each period: a collaborator may replace one)."""

    state: np.ndarray
    yielding: np.ndarray
    yield_until_s: np.ndarray
    backoff_until_s: np.ndarray
    backoff_cmd: np.ndarray
    progress_m: np.ndarray
    t_progress_s: np.ndarray
    stuck_left_m: np.ndarray
    left_m: np.ndarray
    v_cmd_mps: np.ndarray
    q_cmd_mps: np.ndarray
    last_z_m: np.ndarray
    last_th_rad: np.ndarray
    moved_m: np.ndarray


class Follower(NamedTuple):
    """The path follower's arrays (``sim.spatial.navigation.paths.PathFollower``): the padded
    paths (``points``, ``last``, ``after_m``, ``corner2_m`` = ``corner2``, ``free_m``,
    ``capped_m``), the waypoint each robot aims at (``index``) and its current-segment entries
    (``tgt`` = ``tgt_``, ``unit_c``, ``seg_m``, ``after``, ``corner2``, ``switch``, ``beyond``,
    ``free``, ``capped``)."""

    points: np.ndarray
    last: np.ndarray
    index: np.ndarray
    after_m: np.ndarray
    corner2_m: np.ndarray
    free_m: np.ndarray
    capped_m: np.ndarray
    tgt: np.ndarray
    unit_c: np.ndarray
    seg_m: np.ndarray
    after: np.ndarray
    corner2: np.ndarray
    switch: np.ndarray
    beyond: np.ndarray
    free: np.ndarray
    capped: np.ndarray


class Poses(NamedTuple):
    """This period's poses: positions z (x + iy, m), unit headings h, headings th (rad) and
    body velocities vel (x + iy, m/s), (m,) each."""

    z: np.ndarray
    h: np.ndarray
    th: np.ndarray
    vel: np.ndarray


class Wishes(NamedTuple):
    """What :func:`steer_all` writes per robot: the wanted speed ``v`` (m/s) and turn ``w``
    (rad/s), the preferred velocity ``pref`` of ORCA, and flags: ``go`` (driving, not backing
    off), ``stop`` (a yield to end now), ``past`` (past where it last got stuck)."""

    v: np.ndarray
    w: np.ndarray
    pref: np.ndarray
    go: np.ndarray
    stop: np.ndarray
    past: np.ndarray


@njit(cache=True)
def read_poses(pose, fleet, poses):
    """Poses from the motors' read (``pose``: (m, 6) x, y, angle, vx, vy, omega) into
    ``poses``; the odometer and the last poses of ``fleet`` kept."""
    for j in range(pose.shape[0]):
        z = complex(pose[j, 0], pose[j, 1])
        th = pose[j, 2]
        poses.z[j] = z
        poses.th[j] = th
        poses.h[j] = complex(math.cos(th), math.sin(th))
        poses.vel[j] = complex(pose[j, 3], pose[j, 4])
        fleet.moved_m[j] += abs(z - fleet.last_z_m[j])
        fleet.last_z_m[j] = z
        fleet.last_th_rad[j] = th


@njit(cache=True)
def steer_all(t, backoff, yields, avoid, recovering, fleet, fol, shapes, poses, law, out):
    """Every robot's wish this period (``ArrayControl._steer`` without its events).

    Args:
        t: now, s. backoff: some robot backs off (``Schedule.n_backoff``); yields: some
            robot yields; avoid: ORCA is on (the preferred velocities are wanted);
            recovering: some robot has a finite ``stuck_left_m``.
        fleet, fol, poses: :class:`Fleet`, :class:`Follower`, :class:`Poses`; shapes: the
            obstacles (``freewidth.Shapes``).
        law: :class:`sim.spatial.control.kernel.settings.DriveLaw`; out: :class:`Wishes`.

    Returns:
        How many times the follower's arrays changed (waypoints passed, widths refined),
        whether any robot steered, and how many ``stop`` and ``past`` flags were set.
    """
    m = poses.z.shape[0]
    steering = False
    for j in range(m):
        out.stop[j] = out.past[j] = False
        driving = fleet.state[j] == DRIVING
        back = backoff and driving and fleet.backoff_until_s[j] > t
        out.go[j] = driving and not back
        steering = steering or out.go[j] or fleet.yielding[j]
        out.v[j] = out.w[j] = 0.0
    passed = stops = pasts = 0
    if steering:
        for j in range(m):
            target, gap, left, corner2, _, moved_on = aim(j, poses.z[j], fol, shapes, law)
            passed += moved_on
            v, w, pref = steer(poses.h[j].conjugate(), target, gap, corner2, law)
            if not (out.go[j] or fleet.yielding[j]):
                if avoid:
                    out.pref[j] = 0j
                continue
            if avoid:
                out.pref[j] = pref
            fleet.left_m[j] = left
            if yields and fleet.yielding[j] and (left < 0.15 or fleet.yield_until_s[j] < t):
                out.stop[j] = True
                stops += 1
                v = w = 0.0
            elif out.go[j] and left < fleet.progress_m[j]:
                fleet.progress_m[j] = left - law.progress_m
                fleet.t_progress_s[j] = t
                if recovering and left < fleet.stuck_left_m[j] - law.recovered_m:
                    out.past[j] = True
                    pasts += 1
            out.v[j], out.w[j] = v, w
    if backoff:
        for j in range(m):
            if fleet.state[j] == DRIVING and fleet.backoff_until_s[j] > t:
                out.v[j], out.w[j] = fleet.backoff_cmd[j, 0], fleet.backoff_cmd[j, 1]
    return passed, steering, stops, pasts
