"""The second half of the compiled control period: wishes in, wheel commands out.

In the order of ``ArrayControl.period``: ORCA for the robots that steer themselves
(:func:`avoid_robots`), the proximity caps, keep-right and the make-way requests
(:func:`proximity`), both in :func:`commands`; then (:func:`finish`) the wall lines for the
robots ORCA left alone, the speed caps toward obstacles for robots beyond the free width of
their path or backing off blind, and the wheel limits. A robot asked to make way starts to
yield before the walls are looked at, so a make-way request (``Jobs.make_way``, Python) is
handled between the two.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from sim.spatial.control.kernel.avoid import (
    WALL_LINES,
    add_walls,
    binds,
    command,
    meeting,
    robot_lines,
    with_bias,
)
from sim.spatial.control.kernel.drive import drifting, limit, pair_cap, wall_cap
from sim.spatial.control.kernel.neighbours import build_grid, k_nearest, near_robots
from sim.spatial.control.kernel.obstacles import obstacle_points, to_obstacle
from sim.spatial.control.kernel.steering import DRIVING, IDLE


class Work(NamedTuple):
    """Buffers and per-robot results of the second half ((m,) unless said).

    Attributes:
        steering: robots that steer (driving or yielding); solo: ... and do not back off.
        orca: robots whose command ORCA or the wall lines set.
        push: robots that ask the robot in their way to make way.
        rows: robots whose speed is capped toward the nearest obstacle.
        blocker, near: the nearest robot in each one's way and its distance (-1, inf: none).
        idx, dist: (K,) a robot's neighbours; scratch: (m,) ints.
        normal, offset, proj_n, proj_c: (K + W + 2,) lines of one robot's program (W:
            ``wall_lines``).
        seen_z, seen_m: where each robot's distance to the nearest obstacle was last
            measured, and that distance (-inf: never), kept between periods.
        walls: (W,) a robot's obstacle points; points, gaps: (E,) scratch per obstacle edge.
    """

    steering: np.ndarray
    solo: np.ndarray
    orca: np.ndarray
    push: np.ndarray
    rows: np.ndarray
    blocker: np.ndarray
    near: np.ndarray
    idx: np.ndarray
    dist: np.ndarray
    scratch: np.ndarray
    normal: np.ndarray
    offset: np.ndarray
    proj_n: np.ndarray
    proj_c: np.ndarray
    seen_z: np.ndarray
    seen_m: np.ndarray
    walls: np.ndarray
    points: np.ndarray
    gaps: np.ndarray


@njit(cache=True)
def new_work(m, max_neighbours, law, n_edges, orca, push, blocker, near, seen_z, seen_m):
    """The work buffers of one period for ``m`` robots among ``n_edges`` obstacle edges (the
    results and the kept distances given; ``law``: ORCA's settings)."""
    k = max(max_neighbours, 1)
    lines = k + wall_room(law)
    return Work(
        np.zeros(m, dtype=np.bool_),
        np.zeros(m, dtype=np.bool_),
        orca,
        push,
        np.zeros(m, dtype=np.bool_),
        blocker,
        near,
        np.zeros(k, dtype=np.int64),
        np.zeros(k),
        np.zeros(max(m, 1), dtype=np.int64),
        np.zeros(lines, dtype=np.complex128),
        np.zeros(lines),
        np.zeros(lines, dtype=np.complex128),
        np.zeros(lines),
        seen_z,
        seen_m,
        np.zeros(law.wall_lines, dtype=np.complex128),
        np.zeros(n_edges if law.wall_lines > 1 else 0, dtype=np.complex128),
        np.zeros(n_edges if law.wall_lines > 1 else 0),
    )


@njit(cache=True)
def wall_room(orca):
    """Room for a robot's wall and lane lines at the front of its program."""
    return WALL_LINES if orca.wall_lines == 1 else orca.wall_lines + 2


@njit(cache=True)
def walls(j, z, ob, fol, edges, law, orca, work):
    """Robot j's wall and lane lines (``avoid.add_walls``) into ``work.normal``,
    ``work.offset``: from ``ob``, its nearest obstacle point, or with ``wall_lines`` above 1
    from its obstacle points in reach (``obstacles.obstacle_points``); their count."""
    n_pts = -1
    if orca.wall_lines > 1:
        reach = law.radius_m + orca.margin_m + orca.wall_gap_m + law.v_max_mps * orca.tau_obstacle_s
        n_pts = 0  # the nearest obstacle point out of reach: none is in reach
        if abs(ob) < reach:
            n_pts = obstacle_points(z, edges, reach, work.points, work.gaps, work.walls)
    side, left = _lane(j, z, fol)
    return add_walls(
        ob,
        work.walls,
        n_pts,
        side,
        left,
        fol.free[0, j],
        fol.free[1, j],
        law.radius_m,
        orca,
        work.normal,
        work.offset,
    )


@njit(cache=True)
def orca_range_m(law, orca):
    """Centre distance beyond which no half-plane can bind (``orca_range_m``), m."""
    return 2.0 * (law.radius_m + orca.margin_m) + 2.0 * law.v_max_mps * orca.tau_s


@njit(cache=True)
def _lane(j, z, fol):
    """Robot j's minus left offset from its segment and the unit vector to its left."""
    side = ((fol.tgt[j] - z) * fol.unit_c[j]).imag
    return side, 1j * fol.unit_c[j].conjugate()


@njit(cache=True)
def avoid_robots(grid, poses, fol, edges, law, orca, v, w, pref, still_s, work):
    """ORCA for the robots ``work.solo`` whose plan (v along the heading) breaks a half-plane of
    one of their ``max_neighbours`` nearest robots in range (``sim.spatial.law.orca.avoid``):
    their (v, w) replaced, ``work.orca`` set. ``still_s``: (m,) time since each robot's last
    progress, s (the bias's stand rule)."""
    z, h, vel = poses.z, poses.h, poses.vel
    m = z.shape[0]
    k_max = min(orca.max_neighbours, m - 1)
    if k_max < 1:
        return
    reach = orca_range_m(law, orca)
    for i in range(m):
        if not work.solo[i]:
            continue
        count = k_nearest(grid, z, i, reach, k_max, work.idx, work.dist, work.scratch)
        if count == 0:
            continue
        start = wall_room(orca)  # room for the wall lines in front
        robot_lines(
            i,
            z,
            vel,
            work.solo,
            work.idx,
            count,
            law.radius_m,
            law.react_s,
            orca,
            work.normal,
            work.offset,
            start,
        )
        if not binds(work.normal, work.offset, start, start + count, v[i] * h[i]):
            continue
        ob = to_obstacle(z[i], edges)
        n_wall = walls(i, z[i], ob, fol, edges, law, orca, work)
        for s in range(count):  # the robot lines right after the walls
            work.normal[n_wall + s] = work.normal[start + s]
            work.offset[n_wall + s] = work.offset[start + s]
        allow = orca.meet_all or still_s[i] >= orca.bias_stand_s
        allow = allow or meeting(i, z, vel, pref[i], work.idx, count, orca.cos_meet)
        pref_i = with_bias(pref[i], ob, law.radius_m, orca) if allow else pref[i]
        v[i], w[i] = command(
            work.normal,
            work.offset,
            n_wall + count,
            n_wall,
            pref_i,
            h[i],
            law.v_max_mps,
            orca,
            work.proj_n,
            work.proj_c,
        )
        work.orca[i] = True


@njit(cache=True)
def proximity(grid, poses, state, yielding, v, w, v0, avoid, law, reach_m, work):
    """The proximity caps (``DiffDriveController.proximity``) of the robots that steer or have a
    speed, keep-right without avoidance, and the make-way requests of driving robots against a
    standing robot closer than ``reach_m``.

    Returns:
        (True, least distance ahead) if some steering robot is within ``look_m`` of another
        (``v``, ``w``, ``work.blocker``, ``near``, ``push`` written); else (False, a lower
        bound of the distance from a steering robot to the nearest other robot).
    """
    z, h, th = poses.z, poses.h, poses.th
    m = z.shape[0]
    look = law.look_m
    far2 = look * look * (1.0 + 1e-9)
    apart = grid.side
    capped = False
    closest = np.inf
    for i in range(m):
        work.blocker[i], work.near[i], work.push[i] = -1, np.inf, False
    for i in range(m):
        if not (work.steering[i] or v[i] != 0.0):  # (one that stopped steering this period
            continue  # may still have a speed from it: it is capped as the numpy law caps it)
        n = near_robots(grid, z, i, work.scratch)
        hc_i = h[i].conjugate()
        sign = np.sign(v[i])
        cap = np.inf
        for s in range(n):
            k = work.scratch[s]
            rel = z[k] - z[i]
            d2 = rel.real * rel.real + rel.imag * rel.imag
            if d2 > far2:  # surely beyond look_m: a lower bound of the distance will do
                apart = min(apart, math.sqrt(d2) * (1.0 - 1e-9))
                continue
            dist = max(abs(rel), 1e-9)
            apart = min(apart, dist)
            if not dist < look:
                continue
            capped = True
            cos_i = (rel * hc_i).real
            cos_i /= dist
            toward = cos_i * sign
            if not toward > 0.0:
                continue
            cap = min(cap, pair_cap(rel, dist, cos_i, toward, h[k].conjugate(), v0[i], v0[k], law))
            if toward > law.cos_ahead and (
                dist < work.near[i] or (dist == work.near[i] and k < work.blocker[i])
            ):
                work.near[i], work.blocker[i] = dist, k
        v[i] = max(min(v[i], cap), -cap)
        closest = min(closest, work.near[i])
    if not capped:
        return False, apart
    if closest < law.keep_right_m and not avoid:
        for i in range(m):
            o = work.blocker[i]
            if work.near[i] < law.keep_right_m:
                same = np.cos(th[i] - th[o]) > law.same_way_cos and state[o] == DRIVING
                if not same:
                    w[i] = w[i] - law.keep_right_radps
    if closest < reach_m:
        for i in range(m):
            o = max(work.blocker[i], 0)
            standing = state[o] == IDLE and not yielding[o]
            work.push[i] = state[i] == DRIVING and work.near[i] < reach_m and standing
    return True, closest


@njit(cache=True)
def finish(
    t,
    backoff,
    steer_any,
    avoid,
    state,
    yielding,
    backoff_until,
    poses,
    fol,
    shapes,
    edges,
    law,
    orca,
    v,
    w,
    v0,
    q0,
    pref,
    work,
    v_out,
    w_out,
    q_out,
):
    """The wall lines, the obstacle caps and the wheel limits (the rest of
    ``ArrayControl.period`` after the proximity caps): the commands into ``v_out``, ``w_out``,
    ``q_out``. Returns how many free widths were refined (``freewidth.refine``)."""
    z, h = poses.z, poses.h
    m = z.shape[0]
    refined = 0
    for j in range(m):
        work.rows[j] = False
        if steer_any:  # the robot, or where it could stop, beyond the free width of its path
            reach = v[j] if abs(v[j]) >= abs(v0[j]) else v0[j]
            work.rows[j], more = drifting(j, z[j], h[j], reach, fol, shapes, law)
            refined += more
        if backoff and backoff_until[j] > t:  # backing off blind: mind the obstacles too
            work.rows[j] = True
    if avoid and steer_any:  # walls as ORCA lines for the robots ORCA left alone
        base = law.radius_m + orca.margin_m + orca.wall_gap_m
        for j in range(m):
            moving = state[j] == DRIVING or yielding[j]
            if not moving or work.orca[j] or (backoff and backoff_until[j] > t):
                continue
            reach = abs(v[j]) * orca.tau_obstacle_s + base
            reach = max(reach, law.radius_m + orca.lane_near_m) + 1e-6
            if not work.seen_m[j] - abs(z[j] - work.seen_z[j]) < reach:
                continue  # it has not come within reach of a wall since it last looked
            ob = to_obstacle(z[j], edges)
            work.seen_z[j], work.seen_m[j] = z[j], abs(ob)
            if not abs(ob) < reach:
                continue
            n_wall = walls(j, z[j], ob, fol, edges, law, orca, work)
            if n_wall == 0 or not binds(work.normal, work.offset, 0, n_wall, v[j] * h[j]):
                continue
            vj, wj = command(
                work.normal,
                work.offset,
                n_wall,
                n_wall,
                pref[j],
                h[j],
                law.v_max_mps,
                orca,
                work.proj_n,
                work.proj_c,
            )
            v[j], w[j] = min(max(vj, 0.0), abs(v[j])), wj
            work.orca[j] = True
            work.rows[j] = False
    for j in range(m):
        if work.rows[j]:
            v[j] = wall_cap(h[j].conjugate(), v[j], to_obstacle(z[j], edges), law)
        v_out[j], w_out[j], q_out[j] = limit(v[j], w[j], v0[j], q0[j], avoid, work.orca[j], law)
    return refined


@njit(cache=True)
def commands(
    t,
    backoff,
    steer_any,
    prox_due,
    avoid,
    state,
    yielding,
    backoff_until,
    t_progress,
    poses,
    fol,
    edges,
    law,
    orca,
    reach_m,
    v,
    w,
    v0,
    pref,
    work,
):
    """ORCA and the proximity caps, keep-right and the make-way requests (``finish`` is
    next).

    Returns:
        (capped, distance, requests): ``capped`` and ``distance`` as :func:`proximity`
        returns them (False, inf when it was not due); ``requests``: some robot asks another
        to make way (``work.push``; ``v`` holds the capped speeds).
    """
    m = poses.z.shape[0]
    for j in range(m):
        work.steering[j] = state[j] == DRIVING or yielding[j]
        work.solo[j] = work.steering[j] and not (backoff and backoff_until[j] > t)
        work.orca[j] = False
    side = law.look_m
    if avoid:
        side = max(side, orca_range_m(law, orca))
    grid = build_grid(poses.z, side)
    if avoid and steer_any:
        avoid_robots(grid, poses, fol, edges, law, orca, v, w, pref, t - t_progress, work)
    capped, distance = False, np.inf
    if prox_due:
        capped, distance = proximity(
            grid, poses, state, yielding, v, w, v0, avoid, law, reach_m, work
        )
    requests = False
    if capped:
        for j in range(m):
            requests = requests or work.push[j]
    return capped, distance, requests
