"""Whether the stuck check, the arrival check and the site queues have anything to do this
period, compiled.

Three checks run on a schedule of their own: the stuck check (``Jobs.check_stuck``), the
arrival check (``sim.spatial.control.arrival.arrive``) and, with collision avoidance on, the
site queues (``sim.spatial.sites.Sites.queue``). The stuck check is due when the robot longest
without progress could first be stuck. The arrival check and the site queues are due every
period while a robot drives near its site and, while none is near, when the nearest could
first come near. Most of those periods a check does nothing but set its next time.
:func:`stuck_next`, :func:`arrival_next` and :func:`queue_next` answer, inside the control
period, whether this is such a period and which kind of next time the check would set: now
(``NOW``), never (``NEVER``), or a later time (``LATER``), which the caller computes with the
check's own code (``Jobs.next_stuck_check_s``, ``arrival.next_arrival_check_s``,
``Sites.later_check_s``), so it is the very same number. If every check due is such, the
period runs through without stopping for Python.

Each is its Python check's own test, element by element in the same arithmetic:

- the stuck check does nothing else while no robot has been without progress for over
  ``stuck_timeout_s`` (the same minimum and subtraction: exact); its next time is later;
- the arrival check does nothing else when no robot driving to its site is within
  ``arrive_tol_m`` of it (none starts work) and, with avoidance on, every one in the arrival
  zone already has a slot, holds in a queue or before a passage, or finds no standing robot on
  its service point (``Sites.take_slots`` passes it by); without avoidance, when none is in
  the zone. Its next time is now if one is in the zone, else later;
- the site queues do nothing else when no robot is to be let in or held (a driving robot not
  let in, within ``queue_m`` of its site or within ``crowd_m`` of a robot holding for the same
  site) and no idle robot stands within ``queue_m`` of a site that robots come to
  (``Sites.clear_loiterers``'s first test). Their next time is now while some robot drives
  within ``queue_m`` of its site, never while none drives, else later.

Distances are libm's hypot, which may differ from numpy's in the last bit: a distance within
``UNSURE_M`` of the limit it is compared with makes the test say ``ACTS``, and Python decides.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from sim.spatial.control.kernel.steering import DRIVING, IDLE, Fleet


class Sites(NamedTuple):
    """What the quiet tests read besides the fleet and the poses (``views.sites_of``).

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
        stuck_timeout_s: a driving robot this long without progress is stuck, s.
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
    stuck_timeout_s: float


ACTS, NOW, LATER, NEVER = 0, 1, 2, 3  # what a check would do: act, or only set its next time
UNSURE_M = 1e-9  # a distance this close to a limit is left to Python (numpy's hypot may differ)


@njit(cache=True)
def _gap(a: complex, b: complex) -> float:
    """``np.abs(a - b)`` to within an ulp or two (the same subtraction, libm's hypot): each
    comparison with it below leaves a distance within ``UNSURE_M`` of its limit to Python."""
    d = a - b
    return math.hypot(d.real, d.imag)


@njit(cache=True)
def _unsure(gap: float, limit: float) -> bool:
    """True if ``gap`` is too close to ``limit`` for the kernel to tell the side numpy sees."""
    return abs(gap - limit) <= UNSURE_M


@njit(cache=True)
def _maybe_within(gap: float, limit: float) -> bool:
    """True unless numpy surely sees ``gap >= limit`` (``gap < limit``, or :func:`_unsure`)."""
    return gap < limit + UNSURE_M


@njit(cache=True)
def arrival_next(fleet: Fleet, z: np.ndarray, go: np.ndarray, s: Sites, avoid: bool) -> int:
    """What ``arrive`` would do (``z`` the poses, ``go`` the robots driving to a site,
    ``avoid``: collision avoidance on): ``ACTS``, or only set its next check to now (``NOW``:
    some robot is in its arrival zone) or to a later time (``LATER``)."""
    m = z.shape[0]
    in_zone = False
    for j in range(m):
        if not go[j]:
            continue
        gap = _gap(s.site[j], z[j])
        if _unsure(gap, s.zone_m) or _unsure(gap, s.tol_m):
            return ACTS
        if gap > s.zone_m:
            continue
        in_zone = True
        if gap <= s.tol_m or not avoid:
            return ACTS  # it starts work; without avoidance, the zone's own rule
        if s.slotted[j] or s.holding[j] or s.held[j]:
            continue
        for k in range(m):  # a standing robot on its service point: take_slots acts
            if fleet.state[k] != DRIVING and not fleet.yielding[k]:
                if _maybe_within(_gap(z[k], s.site[j]), s.room_m):
                    return ACTS
    return NOW if in_zone else LATER


@njit(cache=True)
def queue_next(t: float, fleet: Fleet, s: Sites) -> int:
    """What ``Sites.queue(t)`` would do: ``ACTS``, or only set its next check to now (``NOW``:
    some robot drives within ``queue_m`` of its site), to a later time (``LATER``) or to
    never (``NEVER``: no robot drives)."""
    m = fleet.state.shape[0]
    z = fleet.last_z_m
    driving = np.zeros(m, dtype=np.bool_)
    close = np.zeros(m, dtype=np.bool_)
    any_driving = False
    any_close = False
    any_holding = False
    for j in range(m):
        driving[j] = (
            fleet.state[j] == DRIVING
            and fleet.backoff_until_s[j] <= t
            and not (s.replan[j] or s.blocked[j] or s.held[j])
        )
        gap = _gap(z[j], s.service[j])
        if _unsure(gap, s.queue_m):
            return ACTS
        close[j] = gap < s.queue_m
        any_holding = any_holding or s.holding[j]
        if not driving[j]:
            continue
        any_driving = True
        if close[j]:
            any_close = True
            if not s.admitted[j]:
                return ACTS  # let in or held
    if not any_driving:
        return NEVER  # Sites.queue returns at once: nothing to check until one drives
    if any_holding:  # a robot not let in, near one holding for the same site, joins the queue
        for j in range(m):
            if not driving[j] or s.admitted[j]:
                continue
            for h in range(m):
                if not s.holding[h]:
                    continue
                same = _maybe_within(_gap(s.service[j], s.service[h]), 1e-6)
                if same and _maybe_within(_gap(z[j], z[h]), s.crowd_m):
                    return ACTS
    for i in range(m):  # Sites.clear_loiterers: an idle robot near a site robots come to
        if fleet.state[i] != IDLE or fleet.yielding[i] or s.broken[i]:
            continue
        for c in range(m):
            coming = driving[c] and ((s.admitted[c] and close[c]) or s.holding[c])
            if coming and _maybe_within(_gap(z[i], s.service[c]), s.queue_m):
                return ACTS
    return NOW if any_close else LATER


@njit(cache=True)
def stuck_next(fleet: Fleet, t: float, s: Sites) -> int:
    """What ``Jobs.check_stuck`` would do: ``ACTS`` if some robot has been without progress
    for over ``stuck_timeout_s`` (one driving may recover), else only set its next check to
    when the stalest could be (``LATER``). The same minimum and subtraction, so exact."""
    stalest = np.inf
    for j in range(fleet.t_progress_s.shape[0]):
        if fleet.t_progress_s[j] < stalest:
            stalest = fleet.t_progress_s[j]
    return ACTS if t - stalest > s.stuck_timeout_s else LATER
