"""Whether the arrival check and the site queues have anything to do this period, compiled.

With collision avoidance on, two checks are due every period while a robot drives near its
site: the arrival check (``sim.spatial.control.arrival.arrive``) and the site queues
(``sim.spatial.sites.Sites.queue``). Most of those periods neither does anything but ask to be
called again. :func:`arrival_quiet` and :func:`queue_quiet` answer, inside the control period,
whether this is such a period; if so the period runs through without stopping for Python, and
the caller only sets the checks' next times to now, as the checks would have.

Each is its Python check's own test, element by element in the same arithmetic:

- the arrival check is quiet when no robot driving to its site is within ``arrive_tol_m`` of it
  (none starts work), some is within the arrival zone (else the check schedules a later time)
  and every one in the zone already has a slot, holds in a queue or before a passage, or finds
  no standing robot on its service point (``Sites.take_slots`` passes it by);
- the site queues are quiet when some robot drives within ``queue_m`` of its site (else
  ``Sites.queue`` schedules its next check), no robot is to be let in or held (a driving robot
  not let in, within ``queue_m`` of its site or within ``crowd_m`` of a robot holding for the
  same site) and no idle robot stands within ``queue_m`` of a site that robots come to
  (``Sites.clear_loiterers``'s first test).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from sim.spatial.control.kernel.steering import DRIVING, IDLE, Fleet


class Sites(NamedTuple):
    """What the two checks read besides the fleet and the poses (``views.sites_of``).

    Attributes:
        queue_m, crowd_m: ``[spatial.queue]``'s distances, m.
        tol_m, zone_m: ``arrive_tol_m`` and the arrival zone (``arrive_tol_m`` + 2
            ``reach_m``), m.
        room_m: a standing robot closer than this to a service point takes it (two radii and
            half ``slot_gap_m``), m.
        site: (m,) where each robot drives to (its service point or its slot), x + iy, m.
        service: (m,) each robot's task site, x + iy, m.
        admitted, holding, slotted: (m,) let in to its site; holding in its queue; sent to a
            slot.
        blocked, held, broken, replan: (m,) waiting for a repair; held by the traffic rules;
            broken; to plan its path again.
    """

    queue_m: float
    crowd_m: float
    tol_m: float
    zone_m: float
    room_m: float
    site: np.ndarray
    service: np.ndarray
    admitted: np.ndarray
    holding: np.ndarray
    slotted: np.ndarray
    blocked: np.ndarray
    held: np.ndarray
    broken: np.ndarray
    replan: np.ndarray


@njit(cache=True)
def _gap(a: complex, b: complex) -> float:
    """``np.abs(a - b)``: the same subtraction, the same hypot."""
    d = a - b
    return math.hypot(d.real, d.imag)


@njit(cache=True)
def arrival_quiet(fleet: Fleet, z: np.ndarray, go: np.ndarray, s: Sites) -> bool:
    """True if ``arrive`` (avoidance on) would change nothing but its next check (set to now):
    ``z`` the poses, ``go`` the robots driving to a site."""
    m = z.shape[0]
    in_zone = False
    for j in range(m):
        if not go[j]:
            continue
        gap = _gap(s.site[j], z[j])
        if gap > s.zone_m:
            continue
        in_zone = True
        if gap <= s.tol_m:
            return False  # it starts work
        if s.slotted[j] or s.holding[j] or s.held[j]:
            continue
        for k in range(m):  # a standing robot on its service point: take_slots acts
            if fleet.state[k] != DRIVING and not fleet.yielding[k]:
                if _gap(z[k], s.site[j]) < s.room_m:
                    return False
    return in_zone


@njit(cache=True)
def queue_quiet(t: float, fleet: Fleet, s: Sites) -> bool:
    """True if ``Sites.queue(t)`` would change nothing but its next check (set to ``t``)."""
    m = fleet.state.shape[0]
    z = fleet.last_z_m
    driving = np.zeros(m, dtype=np.bool_)
    close = np.zeros(m, dtype=np.bool_)
    any_close = False
    any_holding = False
    for j in range(m):
        driving[j] = (
            fleet.state[j] == DRIVING
            and fleet.backoff_until_s[j] <= t
            and not (s.replan[j] or s.blocked[j] or s.held[j])
        )
        close[j] = _gap(z[j], s.service[j]) < s.queue_m
        if driving[j] and close[j]:
            any_close = True
            if not s.admitted[j]:
                return False  # let in or held
        any_holding = any_holding or s.holding[j]
    if not any_close:
        return False  # no robot near its site: Sites.queue schedules its next check
    if any_holding:  # a robot not let in, near one holding for the same site, joins the queue
        for j in range(m):
            if not driving[j] or s.admitted[j]:
                continue
            for h in range(m):
                if (
                    s.holding[h]
                    and _gap(s.service[j], s.service[h]) < 1e-6
                    and _gap(z[j], z[h]) < s.crowd_m
                ):
                    return False
    for i in range(m):  # Sites.clear_loiterers: an idle robot near a site robots come to
        if fleet.state[i] != IDLE or fleet.yielding[i] or s.broken[i]:
            continue
        for c in range(m):
            coming = driving[c] and ((s.admitted[c] and close[c]) or s.holding[c])
            if coming and _gap(z[i], s.service[c]) < s.queue_m:
                return False
    return True
