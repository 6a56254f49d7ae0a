"""Arrival at a task site, one rule for the compiled and the numpy control periods.

A driving robot within ``arrive_tol_m`` of its site starts work. With avoidance on, a robot in
the zone round a site takes a slot there (``Sites.take_slots``: no pushing in); without it, a
robot touching one that stands nearer the site works beside it (the site is taken). The next
check is scheduled for when the driving robot nearest its arrival zone could first be in it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sim.spatial.control.protocol import ControlParts
from sim.spatial.law.drive import next_check_s
from sim.states import DRIVING


def arrive(
    p: ControlParts,
    z: np.ndarray,
    go: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    t: float,
    pairs: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = None,
) -> None:
    """Robots at their site (or beside robots standing there) start work; schedule the next
    check.

    Args:
        p: the world's parts.
        z: (n,) robot positions, x + iy, m.
        go: (n,) the robots driving to a site when the period began (a robot whose task the
            stuck check has failed since is among them, and is passed by).
        v, w: (n,) this period's commands, handed to the robots that start work.
        t: the time, s.
        pairs: neighbour pairs (i, k) of the positions, for large fleets: a queued robot is
            then tested against its neighbours only (the same answer: touching robots are
            neighbours); None tests every queued robot against every standing one.
    """
    f, tol, reach = p.fleet, p.arrive_tol_m, p.reach_m
    gap = np.abs(f.site - z)
    zone = tol + 2 * reach
    there = go & (gap <= zone) & (f.task >= 0)  # a robot the stuck check failed since has none
    if np.count_nonzero(there):  # near the site: arrived, or beside robots standing there
        if p.avoid:  # no pushing in: a slot, or wait for the service point
            p.jobs.sites.take_slots((there & (gap > tol)).nonzero()[0].tolist(), z, t)
            queue = np.zeros(0, dtype=int)
        else:
            queue = (there & (gap > tol) & (f.near_m <= reach)).nonzero()[0]
        there &= gap <= tol
        if queue.size:  # touching a robot that stands nearer the site: the site is taken,
            # and working beside the robots already there counts as arrived
            standing = (f.state != DRIVING) & ~f.yielding
            if pairs is None:  # every queued robot, every standing one
                zs = z[standing.nonzero()[0]]
                nearer = np.abs(zs[None, :] - f.site[queue, None]) < gap[queue, None]
                nearer &= np.abs(zs[None, :] - z[queue, None]) <= reach  # touching
                there[queue] = nearer.any(axis=1)
            else:  # ... against its neighbours only (look_m > reach_m)
                i, k = pairs(z)
                queued = np.zeros(len(z), dtype=bool)
                queued[queue] = True
                sel = (queued[i] & standing[k]).nonzero()[0]
                i, k = i[sel], k[sel]
                nearer = np.abs(z[k] - f.site[i]) < gap[i]
                nearer &= np.abs(z[k] - z[i]) <= reach  # touching
                there[queue] = False
                there[i[nearer]] = True
        p.jobs.start_work(there.nonzero()[0].tolist(), v, w, t)
    p.schedule.site_check_s = next_arrival_check_s(p, gap, go, t)


def next_arrival_check_s(p: ControlParts, gap: np.ndarray, go: np.ndarray, t: float) -> float:
    """When the driving robot nearest its arrival zone could first be in it (now, if one is):
    ``gap`` (n,) each robot's distance to its site, ``np.abs(site - z)``, m; ``go`` the robots
    driving to a site; ``t`` now, s."""
    c, zone = p.controller, p.arrive_tol_m + 2 * p.reach_m
    nearest = float(np.where(go, gap, np.inf).min()) - zone
    return next_check_s(t, nearest, c.speed_bound * c.v_max_mps)
