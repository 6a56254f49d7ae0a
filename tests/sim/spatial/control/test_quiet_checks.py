"""The compiled control period's quiet tests (``sim.spatial.control.kernel.quiet``): when they
say the stuck check, the arrival check and the site queues have nothing to do but set their
next times, the Python checks indeed change nothing else, and the times the period sets are
theirs.

The runs below check every period the kernel ran through that way: right after the period set
the next times (``CompiledControl._quiet``), the Python checks it skipped run on the world as
it stands, and must change nothing at all, their next times included (so the run goes on as it
would have).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim.spatial.control.compiled as compiled
from learning.episode import run_protocol
from scenarios.protocol import RunSpec, build_run
from sim.scenario import QueueSpec
from sim.spatial.control.arrival import arrive
from sim.spatial.control.kernel import quiet as kq
from sim.spatial.control.kernel.steering import Fleet
from sim.spatial.control.kernel.views import fleet_of, sites_of
from sim.states import DRIVING, WORKING
from tests.worlds import SITE, at, give, make_world, orca_world, service

QUEUE_M = QueueSpec().queue_m
KINDS = {kq.NOW: "now", kq.LATER: "later", kq.NEVER: "never"}


def _state(world) -> dict:
    """Everything the two checks may change: fleet, schedule, site queues, paths, marks."""
    jobs, fol = world.jobs, world.follower
    out = {f"fleet.{k}": v for k, v in world.fleet.state_arrays().items()}
    out |= {f"schedule.{k}": v for k, v in world.schedule.state_arrays().items()}
    out |= {f"sites.{k}": v for k, v in jobs.sites.state_arrays().items()}
    out |= {"blocked": jobs.blocked.copy(), "began": jobs.jams.began.copy()}
    out |= {"points": fol.points.copy(), "last": fol.last.copy(), "index": fol.index.copy()}
    out["paths_set"] = np.array(fol.paths_set_)
    return out


def _watch(monkeypatch) -> dict:
    """Check every period the kernel found quiet (see above); count them by check and by the
    kind of next time set."""
    seen = {"stuck": 0, "arrival": 0, "queue": 0, "now": 0, "later": 0, "never": 0}
    inner = compiled.CompiledControl._quiet

    def quiet(self, t, stuck_kind, site_kind, queue_kind):
        inner(self, t, stuck_kind, site_kind, queue_kind)
        p, world = self.parts, seen["world"]
        before = _state(world)
        go = self.wishes_[3].copy()
        if stuck_kind != kq.ACTS:
            p.jobs.check_stuck(go, t)
            seen["stuck"] += 1
            seen[KINDS[stuck_kind]] += 1
        if site_kind != kq.ACTS:
            m = len(p.fleet.state)
            arrive(p, self.poses_[0].copy(), go, np.ones(m), np.ones(m), t)
            seen["arrival"] += 1
            seen[KINDS[site_kind]] += 1
        if queue_kind != kq.ACTS:
            p.jobs.sites.queue(t)
            seen["queue"] += 1
            seen[KINDS[queue_kind]] += 1
        after = _state(world)
        assert before.keys() == after.keys()
        for key in before:
            assert np.array_equal(before[key], after[key]), (key, t)

    monkeypatch.setattr(compiled.CompiledControl, "_quiet", quiet)
    return seen


@pytest.mark.parametrize(
    ("name", "allocator", "seed", "avoidance"),
    [
        ("paper_spatial", "market", 0, "orca"),
        ("warehouse", "expt", 3, "orca"),
        ("paper_spatial", "ql", 1, "none"),
    ],
)
def test_a_period_found_quiet_changes_nothing_in_the_python_checks(
    name, allocator, seed, avoidance, monkeypatch
):
    seen = _watch(monkeypatch)
    part = (("stream.n_sets", 1), ("stream.learn_sets", 1), ("stream.test_sets", 1))
    part += (("spatial.avoidance", avoidance),)
    scenario, stream, world, cost, alloc, rng = build_run(
        RunSpec(name, allocator, "distance", seed, part)
    )
    assert isinstance(world.control, compiled.CompiledControl)
    assert world.jobs.avoid is (avoidance == "orca")
    seen["world"] = world
    run_protocol(scenario, stream, alloc, world, cost, rng, trace=False)
    # not vacuous: each check was found quiet often, both with a robot near (next time: now)
    # and with none (a later time)
    assert seen["stuck"] >= 50 and seen["arrival"] >= 100 and seen["later"] >= 100
    if avoidance == "orca":
        assert seen["queue"] >= 100 and seen["now"] >= 100
    else:
        assert seen["queue"] == 0 and seen["now"] == 0  # no queues; in the zone: Python decides


# ---- scenes: each branch of the three tests, against what the Python check does ----------


def _queue_next(w, t: float) -> int:
    fleet, sites = Fleet(*fleet_of(w.fleet)), kq.Sites(*sites_of(w.control.parts))
    return kq.queue_next(t, fleet, sites)


def _arrival_next(w) -> int:
    f = w.fleet
    go = f.state == DRIVING
    fleet, sites = Fleet(*fleet_of(f)), kq.Sites(*sites_of(w.control.parts))
    return kq.arrival_next(fleet, f.last_z_m.copy(), go, sites, w.jobs.avoid)


def _quiet_queue(w, t: float) -> bool:
    return _queue_next(w, t) != kq.ACTS


def _quiet_arrival(w) -> bool:
    return _arrival_next(w) != kq.ACTS


def _arrive(w, t: float) -> None:
    """The Python arrival check on the world as it stands."""
    m = len(w.fleet.state)
    z = w.fleet.last_z_m.copy()
    arrive(w.control.parts, z, w.fleet.state == DRIVING, np.zeros(m), np.zeros(m), t)


def _let_in_near(w, j: int, off: complex) -> None:
    """Robot j drives to SITE, let in, ``off`` from it (within queue_m)."""
    give(w, [j], [(10.0, 5.0)])
    w.fleet.last_z_m[j] = SITE + off
    w.jobs.sites.admitted[j] = True


@pytest.mark.parametrize(("idle_off_m", "quiet"), [(1.0, False), (QUEUE_M + 0.5, True)])
def test_an_idle_robot_loitering_at_a_site_a_robot_is_let_in_to_keeps_the_queue_busy(
    idle_off_m, quiet
):
    """Robot 1 is let in and 1 m from the site; idle robot 2 stands ``idle_off_m`` off it.
    Within queue_m the queue sends robot 2 out: not quiet. Farther, the queue has nothing to
    do: quiet, and the Python queue changes nothing but its next check."""
    w = orca_world([(18.0, 1.0), (2.0, 5.0), (10.0, 5.0 + idle_off_m)])
    _let_in_near(w, 1, -1.0)
    t = at(w, 4.0)
    assert _quiet_queue(w, t) is quiet
    w.jobs.sites.queue(t)
    assert w.fleet.yielding.tolist() == [False, False, not quiet]
    assert w.jobs.sites.queue_check_s == t


def test_a_robot_held_before_a_passage_leaves_the_queue_quiet():
    """Robot 2, not let in, stands 1 m from the site but is held by the traffic rules: the
    queue passes it by (it is not driving for the queue), so with robot 1 let in close by the
    period is quiet."""
    w = orca_world([(18.0, 1.0), (2.0, 5.0), (2.0, 8.0)])
    _let_in_near(w, 1, -1.0)
    give(w, [2], [(10.0, 5.0)], ids=[1])
    w.fleet.last_z_m[2] = SITE + 1.0j
    t = at(w, 4.0)
    assert not _quiet_queue(w, t)  # robot 2 would be let in
    w.jobs.held[2] = True
    assert _quiet_queue(w, t)


def test_with_nobody_driving_near_a_site_the_queue_is_quiet_until_the_nearest_could_come():
    """Robot 1 is let in 8 m from its site: the queue has nothing to do but look again when
    robot 1 could first come within queue_m at the bound on its speed (``LATER``). The period
    sets that time (``CompiledControl._quiet``), to the bit the time ``Sites.queue`` sets."""
    w = orca_world([(18.0, 1.0), (2.0, 5.0)], control="compiled")
    give(w, [1], [(10.0, 5.0)])
    w.jobs.sites.admitted[1] = True
    t = at(w, 4.0)
    assert _queue_next(w, t) == kq.LATER
    w.control._quiet(t, kq.ACTS, kq.ACTS, kq.LATER)
    nxt = w.jobs.sites.queue_check_s
    c = w.control.parts.controller
    expected = t + (8.0 - QUEUE_M) / (c.speed_bound * w.follower.v_max_mps)
    assert nxt == pytest.approx(expected, rel=1e-12) and nxt > t
    w.jobs.sites.queue_check_s = -np.inf
    w.jobs.sites.queue(t)
    assert w.jobs.sites.queue_check_s == nxt


def test_with_no_robot_driving_the_queue_is_quiet_for_good():
    """No robot has a task, so none drives: ``Sites.queue`` returns at once with its next check
    at infinity; the kernel's test says ``NEVER``, and the period sets infinity."""
    w = orca_world([(18.0, 1.0), (2.0, 5.0)], control="compiled")
    t = at(w, 4.0)
    assert _queue_next(w, t) == kq.NEVER
    w.control._quiet(t, kq.ACTS, kq.ACTS, kq.NEVER)
    assert w.jobs.sites.queue_check_s == math.inf
    w.jobs.sites.queue_check_s = -np.inf
    w.jobs.sites.queue(t)
    assert w.jobs.sites.queue_check_s == math.inf


@pytest.mark.parametrize("avoidance", ["orca", "none"])
def test_with_no_robot_in_an_arrival_zone_the_arrival_check_is_quiet_until_one_could_be(
    avoidance,
):
    """Robot 1 drives to the site 8 m off: ``arrive`` starts no work and looks again when robot
    1 could first be in the arrival zone. The kernel's test says ``LATER`` with and without
    avoidance, and the period sets the very time ``arrive`` sets."""
    w = make_world([(18.0, 1.0), (2.0, 5.0)], control="compiled", avoidance=avoidance)
    give(w, [1], [(10.0, 5.0)])
    t = at(w, 4.0)
    assert _arrival_next(w) == kq.LATER
    w.control.poses_[0][:] = w.fleet.last_z_m
    w.control.wishes_[3][:] = w.fleet.state == DRIVING
    w.control._quiet(t, kq.ACTS, kq.LATER, kq.ACTS)
    nxt = w.schedule.site_check_s
    p = w.control.parts
    zone, c = p.arrive_tol_m + 2 * p.reach_m, p.controller
    expected = t + (8.0 - zone) / (c.speed_bound * c.v_max_mps)
    assert nxt == pytest.approx(expected, rel=1e-12) and nxt > t
    _arrive(w, t)
    assert w.schedule.site_check_s == nxt
    assert w.fleet.state[1] == DRIVING  # no work started


def test_without_avoidance_a_robot_in_the_arrival_zone_leaves_it_to_python():
    """Without avoidance a robot in the zone (not yet there) may work beside one standing
    nearer: the kernel does not decide that rule, so it says ``ACTS``; in the zone with
    avoidance and nothing on the service point it is quiet, its next check now."""
    for avoidance, kind in (("none", kq.ACTS), ("orca", kq.NOW)):
        w = make_world([(18.0, 1.0), (2.0, 5.0)], avoidance=avoidance)
        give(w, [1], [(10.0, 5.0)])
        w.fleet.last_z_m[1] = SITE - 0.4  # in the zone, outside arrive_tol_m
        assert _arrival_next(w) == kind, avoidance


def test_a_distance_at_a_limit_to_the_last_nanometre_is_left_to_python():
    """A robot within ``UNSURE_M`` of queue_m from its site (numpy's hypot and the kernel's
    may differ in the last bit there): the queue's test says ``ACTS`` whatever the side; a
    micrometre farther it is sure (``LATER``)."""
    w = orca_world([(18.0, 1.0), (2.0, 5.0)])
    give(w, [1], [(10.0, 5.0)])
    w.jobs.sites.admitted[1] = True
    t = at(w, 4.0)
    for off, kind in ((QUEUE_M, kq.ACTS), (QUEUE_M + 1e-10, kq.ACTS), (QUEUE_M + 1e-6, kq.LATER)):
        w.fleet.last_z_m[1] = SITE - off
        assert _queue_next(w, t) == kind, off


@pytest.mark.parametrize(("on_point", "quiet"), [(True, False), (False, True)])
def test_a_robot_standing_on_the_service_point_makes_the_arrival_check_act(on_point, quiet):
    """Robot 0 drives to the site and is in its arrival zone, not there. Robot 1 at work on
    the service point sends it to a slot (``take_slots``): not quiet. With robot 1 at work 3 m
    off nothing happens: quiet, and the Python check leaves robot 0's goal as it was."""
    w = orca_world([(2.0, 5.0), (10.0, 5.0)])
    service(w, SITE - 0.9)
    if not on_point:
        w.fleet.last_z_m[1] = SITE + 3.0j
    assert _quiet_arrival(w) is quiet
    z = w.fleet.last_z_m.copy()
    arrive(w.control.parts, z, w.fleet.state == DRIVING, np.zeros(2), np.zeros(2), at(w, 4.0))
    assert bool(w.fleet.site[0] == SITE) is quiet


def test_a_robot_within_arrival_tolerance_starts_work_and_one_with_a_slot_is_passed_by():
    w = orca_world([(2.0, 5.0), (10.0, 5.0)])
    service(w, SITE - 0.9)
    w.jobs.sites.slotted[0] = True  # already sent to a slot: take_slots passes it by
    assert _quiet_arrival(w)
    w.fleet.last_z_m[0] = SITE - 0.01  # within arrive_tol_m: it starts work
    w.fleet.site[0] = SITE
    assert not _quiet_arrival(w)


def test_a_robot_exactly_arrival_tolerance_off_starts_work_so_the_check_is_not_quiet():
    """``arrive`` starts work at ``gap <= arrive_tol_m``: at exactly 0.25 m (exact in binary)
    the robot arrives, so the period is not quiet, even with a slot that would pass it by."""
    w = orca_world([(2.0, 5.0), (10.0, 8.0)], arrive_tol_m=0.25)
    give(w, [0], [(10.0, 5.0)])
    w.jobs.sites.slotted[0] = True
    w.fleet.last_z_m[0] = SITE - 0.25
    assert abs(w.fleet.site[0] - w.fleet.last_z_m[0]) == 0.25
    assert not _quiet_arrival(w)
    z = w.fleet.last_z_m.copy()
    arrive(w.control.parts, z, w.fleet.state == DRIVING, np.zeros(2), np.zeros(2), at(w, 4.0))
    assert w.fleet.state[0] == WORKING


def test_a_robot_standing_a_room_off_the_service_point_to_the_nanometre_is_left_to_python():
    """Robot 0 is in the arrival zone; robot 1 works ``room_m`` off the service point, where a
    standing robot starts to take it (``take_slots``): within ``UNSURE_M`` of that the arrival
    test says ``ACTS`` whatever the side; a micrometre farther it is sure (``NOW``)."""
    w = orca_world([(2.0, 5.0), (10.0, 5.0)])
    service(w, SITE - 0.9)
    room = kq.Sites(*sites_of(w.control.parts)).room_m
    for off, kind in ((room, kq.ACTS), (room + 1e-10, kq.ACTS), (room + 1e-6, kq.NOW)):
        w.fleet.last_z_m[1] = SITE + 1j * off
        assert _arrival_next(w) == kind, off


@pytest.mark.parametrize("stale", [0, 1])
@pytest.mark.parametrize(
    ("without_progress_s", "kind"),
    [(4.0, kq.LATER), (5.0, kq.LATER), (5.5, kq.ACTS)],
)
def test_the_stuck_check_acts_only_past_the_timeout(without_progress_s, kind, stale):
    """Robot ``stale`` drives without progress for 4, 5 (exactly ``stuck_timeout_s``: not yet
    stuck, as ``check_stuck`` compares with ``>``) or 5.5 s. Up to the timeout the check only
    looks again when it could be stuck, and the period sets the very time ``check_stuck`` sets;
    past it the kernel leaves the check to Python, which has the robot recover."""
    w = orca_world([(18.0, 1.0), (2.0, 5.0)], control="compiled", stuck_timeout_s=5.0)
    give(w, [stale], [(10.0, 5.0)])
    t = at(w, 8.0)
    f = w.fleet
    f.t_progress_s[:] = np.inf
    f.t_progress_s[stale] = t - without_progress_s
    fleet, sites = Fleet(*fleet_of(f)), kq.Sites(*sites_of(w.control.parts))
    assert kq.stuck_next(fleet, t, sites) == kind
    if kind == kq.LATER:
        w.control._quiet(t, kq.LATER, kq.ACTS, kq.ACTS)
        nxt = w.schedule.stuck_check_s
        assert nxt == t - without_progress_s + 5.0
        w.schedule.stuck_check_s = -np.inf
        w.jobs.check_stuck(f.state == DRIVING, t)
        assert w.schedule.stuck_check_s == nxt and w.jobs.fired["backoff"] == 0
    else:  # Python's check does act: a recovery rule fires for the robot
        w.jobs.check_stuck(f.state == DRIVING, t)
        assert sum(w.jobs.fired.values()) + sum(w.jobs.jams.fired.values()) >= 1


@pytest.mark.parametrize(
    ("off_m", "site2", "quiet"),
    [(0.8, (10.0, 5.0), False), (1.2, (10.0, 5.0), True), (0.8, (16.0, 8.0), True)],
)
def test_a_robot_near_one_holding_for_the_same_site_joins_its_queue(off_m, site2, quiet):
    """Robot 1 holds in SITE's queue 3 m off (beyond queue_m) while it backs off, so the queue
    does not look at it; robot 2 comes for ``site2`` ``off_m`` beside it, beyond queue_m of its
    site. Within crowd_m (1 m) and for SITE too, robot 2 joins the queue (``Sites.queue``
    acts): not quiet. Farther, or for another site, nothing happens: quiet, the next check
    later."""
    w = orca_world([(18.0, 1.0), (2.0, 5.0), (2.0, 8.0)])
    give(w, [1, 2], [(10.0, 5.0), site2])
    t = at(w, 4.0)
    f, s = w.fleet, w.jobs.sites
    f.last_z_m[1] = SITE - 3.0
    f.last_z_m[2] = SITE - 3.0 + 1j * off_m
    s.holding[1], s.hold_since_s[1] = True, 1.0
    f.backoff_until_s[1] = t + 5.0
    assert _queue_next(w, t) == (kq.LATER if quiet else kq.ACTS)
    s.queue(t)
    assert bool(s.holding[2] or s.admitted[2]) is not quiet
