"""The compiled control period's one entry point: both halves in one call unless an event fires.

:func:`run_period` runs the first half (``steering.steer_all``) and, when nothing needs Python
(no yield ends, no robot gets past where it was stuck, the end of work and the deadlines not
due; the stuck check, the arrival check and the site queues either not due or with nothing to
do but set their next times: ``quiet``), the second half (``commands.commands``,
``commands.finish``) in the same call. Otherwise it returns at the first point where Python
must act, and the caller calls again from the next stage: ``COMMANDS`` after the events,
``FINISH`` after a make-way request.

Arguments arrive as plain tuples of arrays and of numbers, which numba types quickly at each
call; they become the named tuples the kernel reads (``steering.Fleet``, ``Follower``,
``Poses``, ``Wishes``; ``obstacles.Edges``; ``settings.DriveLaw``, ``AvoidLaw``) here.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sim.spatial.control.kernel.commands import commands, finish, new_work
from sim.spatial.control.kernel.freewidth import Shapes
from sim.spatial.control.kernel.obstacles import Edges
from sim.spatial.control.kernel.quiet import (  # noqa: F401 (NOW, LATER, NEVER: the caller's)
    ACTS,
    LATER,
    NEVER,
    NOW,
    Sites,
    arrival_next,
    queue_next,
    stuck_next,
)
from sim.spatial.control.kernel.settings import AvoidLaw, DriveLaw
from sim.spatial.control.kernel.steering import (
    Fleet,
    Follower,
    Poses,
    Wishes,
    read_poses,
    steer_all,
)

START, COMMANDS, FINISH = 0, 1, 2  # where a call begins
DONE, EVENTS, MAKE_WAY = 0, 1, 2  # where it stopped: finished, or Python must act first


@njit(cache=True)
def read_only(pose, fleet_t, poses_t):
    """``steering.read_poses`` alone (before Python replans robots done backing off)."""
    read_poses(pose, Fleet(*fleet_t), Poses(*poses_t))


@njit(cache=True)
def run_period(
    stage,
    t,
    read,
    schedule,
    reach_m,
    pose,
    fleet_t,
    fol_t,
    poses_t,
    wish_t,
    drive_t,
    avoid_t,
    edges_t,
    shapes_t,
    kept,
    sites_t,
    out,
):
    """One control period, or its rest from ``stage``.

    Args:
        stage: ``START``, ``COMMANDS`` or ``FINISH``.
        t: now, s. read: read the poses from ``pose`` first (``START`` only).
        schedule: (avoid, n_backoff, n_yield, n_steer, recovering, stuck_check_s,
            site_check_s, prox_check_s, queue_check_s, next_end_s, next_deadline_s): whether
            ORCA is on, the schedule's counts and flag, and the times its checks are due, s.
        reach_m: a driving robot closer than this to a standing one asks it to make way, m.
        pose: (m, 6) the motors' read; fleet_t, fol_t, poses_t, wish_t, drive_t, avoid_t,
            edges_t, shapes_t: the fields of ``Fleet``, ``Follower``, ``Poses``, ``Wishes``,
            ``DriveLaw``, ``AvoidLaw``, ``Edges``, ``Shapes`` in order.
        kept: (orca flags, seen_z, seen_m), kept between calls (``commands.Work``).
        sites_t: the fields of ``quiet.Sites``: what the stuck check's, the arrival check's and
            the site queues' quiet tests read.
        out: (v, w, q, blocker, near, push), (m,) each, written: the commands (m/s, rad/s,
            m/s), the robot in each one's way, its distance, the make-way requests.

    Returns:
        (status, changes of the follower's arrays (waypoints passed, widths refined), any
        robot steered, yields to stop, robots past where they were stuck, proximity capped,
        distance, stuck_kind, site_kind, queue_kind): ``status`` is ``DONE``, ``EVENTS`` (the
        first half is done; ``wish.stop``, ``wish.past`` and the schedule say what to handle)
        or ``MAKE_WAY`` (``out`` push); ``capped`` and ``distance`` as ``commands.proximity``
        returns them when it ran; ``stuck_kind``, ``site_kind``, ``queue_kind``: the stuck
        check, the arrival check, the site queues were due and had nothing to do but set their
        next time, of this kind (``quiet.NOW``, ``LATER``, ``NEVER``: ``quiet.stuck_next``,
        ``arrival_next``, ``queue_next``), which the caller sets; ``quiet.ACTS`` otherwise.
    """
    avoid, n_backoff, n_yield, n_steer, recovering = schedule[:5]
    stuck_s, site_s, prox_s, queue_s, end_s, deadline_s = schedule[5:]
    fleet, fol, poses = Fleet(*fleet_t), Follower(*fol_t), Poses(*poses_t)
    wish, edges, shapes = Wishes(*wish_t), Edges(*edges_t), Shapes(*shapes_t)
    law, orca = DriveLaw(*drive_t), AvoidLaw(*avoid_t)
    v_out, w_out, q_out, blocker, near, push = out
    m = poses.z.shape[0]
    k, e = orca.max_neighbours, edges.e0.shape[0]
    work = new_work(m, k, orca, e, kept[0], push, blocker, near, kept[1], kept[2])
    passed, steering, stops, pasts = 0, False, 0, 0
    stuck_kind, site_kind, queue_kind = ACTS, ACTS, ACTS
    if stage == START:
        if read:
            read_poses(pose, fleet, poses)
        passed, steering, stops, pasts = steer_all(
            t,
            n_backoff > 0,
            n_yield > 0,
            avoid,
            recovering,
            fleet,
            fol,
            shapes,
            poses,
            law,
            wish,
        )
        due = stops > 0 or pasts > 0
        # Jobs.end_due acts on exactly these three (the site queues, ends of work, deadlines);
        # a rule added there must be added here (the parity test, which calls it every
        # period on the numpy side, would see the difference)
        due = due or t + 1e-9 >= end_s or t > deadline_s
        stuck = steering and t > stuck_s
        arrival, queue = steering and t >= site_s, avoid and t >= queue_s
        if not due and (stuck or arrival or queue):  # Python acts only if one has work
            sites = Sites(*sites_t)
            if stuck:
                stuck_kind = stuck_next(fleet, t, sites)
                due = stuck_kind == ACTS
            if arrival and not due:
                site_kind = arrival_next(fleet, poses.z, wish.go, sites, avoid)
                due = site_kind == ACTS
            if queue and not due:
                queue_kind = queue_next(t, fleet, sites)
                due = queue_kind == ACTS
        if due:
            return EVENTS, passed, steering, stops, pasts, False, np.inf, ACTS, ACTS, ACTS
        stage = COMMANDS
    capped, distance = False, np.inf
    if stage == COMMANDS:
        capped, distance, requests = commands(
            t,
            n_backoff > 0,
            n_steer > 0,
            t >= prox_s,
            avoid,
            fleet.state,
            fleet.yielding,
            fleet.backoff_until_s,
            fleet.t_progress_s,
            poses,
            fol,
            edges,
            law,
            orca,
            reach_m,
            wish.v,
            wish.w,
            fleet.v_cmd_mps,
            wish.pref,
            work,
        )
        if requests:
            return (
                MAKE_WAY, passed, steering, stops, pasts, capped, distance,
                stuck_kind, site_kind, queue_kind,
            )  # fmt: skip
    passed += finish(
        t,
        n_backoff > 0,
        n_steer > 0,
        avoid,
        fleet.state,
        fleet.yielding,
        fleet.backoff_until_s,
        poses,
        fol,
        shapes,
        edges,
        law,
        orca,
        wish.v,
        wish.w,
        fleet.v_cmd_mps,
        fleet.q_cmd_mps,
        wish.pref,
        work,
        v_out,
        w_out,
        q_out,
    )
    return (
        DONE, passed, steering, stops, pasts, capped, distance,
        stuck_kind, site_kind, queue_kind,
    )  # fmt: skip
