"""The compiled control period's quiet tests (``sim.spatial.control.kernel.quiet``): when they
say the arrival check and the site queues have nothing to do, the Python checks indeed change
nothing but their next times.

The runs below keep the kernel from ever finding a period quiet (distances of -1 m in what it
reads), so every due check stops the period and runs in Python, as it did before the quiet
tests. At each such stop the two quiet tests are asked with the real distances; where they say
"quiet", the world's state before and after the Python checks must be the same, the checks'
next times excepted (set to now).
"""

from __future__ import annotations

import numpy as np
import pytest

import sim.spatial.control.compiled as compiled
from learning.episode import run_protocol
from scenarios.protocol import RunSpec, build_run
from sim.scenario import QueueSpec
from sim.spatial.control.arrival import arrive
from sim.spatial.control.kernel import period
from sim.spatial.control.kernel import quiet as kq
from sim.spatial.control.kernel.steering import Fleet
from sim.spatial.control.kernel.views import fleet_of, sites_of
from sim.states import DRIVING, WORKING
from tests.worlds import SITE, at, give, orca_world, service

QUEUE_M = QueueSpec().queue_m


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
    """Run the world as before the quiet tests and check them at every stop (see above)."""
    seen = {"arrival": 0, "queue": 0, "stops": 0, "checked": 0, "pending": None}

    def never_quiet(parts):
        t = sites_of(parts)
        return (-1.0, t[1], t[2], -1.0, *t[4:])  # queue_m, zone_m < 0: nothing is ever quiet

    monkeypatch.setattr(compiled, "sites_of", never_quiet)
    inner = compiled.CompiledControl._call

    def call(self, stage, t, read, out):
        p = self.parts
        if stage == period.COMMANDS and seen["pending"] is not None:
            before, arrival, queue = seen["pending"]
            seen["pending"] = None
            after = _state(seen["world"])
            if arrival:
                before["schedule.site_check_s"] = np.array(t)
            if queue:
                before["sites.queue_check_s"] = np.array(t)
            assert before.keys() == after.keys()
            for key in before:
                assert np.array_equal(before[key], after[key]), (key, t)
            seen["checked"] += 1
        res = inner(self, stage, t, read, out)
        if stage != period.START or res[0] != period.EVENTS:
            return res
        _, _, steering, stops, pasts = res[:5]
        sch = p.schedule
        if stops or pasts or (steering and t > sch.stuck_check_s):
            return res
        if t + 1e-9 >= sch.next_end_s or t > sch.next_deadline_s:
            return res
        arrival = steering and t >= sch.site_check_s
        queue = p.avoid and t >= p.jobs.sites.queue_check_s
        sites, fleet = kq.Sites(*sites_of(p)), Fleet(*fleet_of(p.fleet))
        go = self.wishes_[3]
        if arrival and not (p.avoid and kq.arrival_quiet(fleet, self.poses_[0], go, sites)):
            return res
        if queue and not kq.queue_quiet(t, fleet, sites):
            return res
        seen["arrival"] += arrival
        seen["queue"] += queue
        seen["stops"] += 1
        seen["pending"] = (_state(seen["world"]), arrival, queue)
        return res

    monkeypatch.setattr(compiled.CompiledControl, "_call", call)
    return seen


@pytest.mark.parametrize(
    ("name", "allocator", "seed"),
    [("paper_spatial", "market", 0), ("warehouse", "expt", 3)],
)
def test_a_period_found_quiet_changes_nothing_in_the_python_checks(
    name, allocator, seed, monkeypatch
):
    seen = _watch(monkeypatch)
    part = (("stream.n_sets", 1), ("stream.learn_sets", 1), ("stream.test_sets", 1))
    scenario, stream, world, cost, alloc, rng = build_run(
        RunSpec(name, allocator, "distance", seed, part)
    )
    assert isinstance(world.control, compiled.CompiledControl) and world.jobs.avoid
    seen["world"] = world
    run_protocol(scenario, stream, alloc, world, cost, rng, trace=False)
    # not vacuous: each test found quiet periods, and each was checked
    assert seen["arrival"] >= 100 and seen["queue"] >= 100
    assert seen["checked"] == seen["stops"] and seen["pending"] is None


# ---- scenes: each branch of the two tests, against what the Python check does ------------


def _quiet_queue(w, t: float) -> bool:
    fleet, sites = Fleet(*fleet_of(w.fleet)), kq.Sites(*sites_of(w.control.parts))
    return kq.queue_quiet(t, fleet, sites)


def _quiet_arrival(w) -> bool:
    f = w.fleet
    go = f.state == DRIVING
    fleet, sites = Fleet(*fleet_of(f)), kq.Sites(*sites_of(w.control.parts))
    return kq.arrival_quiet(fleet, f.last_z_m.copy(), go, sites)


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


def test_nobody_driving_near_a_site_is_no_quiet_period_but_a_later_check():
    w = orca_world([(18.0, 1.0), (2.0, 5.0)])
    give(w, [1], [(10.0, 5.0)])
    w.jobs.sites.admitted[1] = True
    assert not _quiet_queue(w, at(w, 4.0))  # 8 m off: Sites.queue schedules a later check


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
