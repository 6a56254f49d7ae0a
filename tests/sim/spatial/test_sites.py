"""``sim.spatial.sites.Sites`` method by method: what each writes, what it returns, when it asks for
the schedule to be refreshed, and its checkpoint. Written for the gaps mutation run H found
(README, "Testing"), and the queue's rules driven directly through ``Jobs`` with collision
avoidance on: who is let in, who holds and is drawn as waiting, who drives out, who takes a
service slot. The queue in a whole run is in ``tests/behaviour/test_site_queue.py``.

Geometry used throughout: robots of radius 0.25 m, reach 0.6 m (``PymunkWorld.reach_m_``),
service slots on a ring of 0.85 m round a service point, a robot standing within 0.675 m of a
place takes it.
"""

from __future__ import annotations

import io

import numpy as np
import pytest

from sim.scenario import MakeWaySpec, QueueSpec
from sim.spatial.control.kernel import quiet as compiled_quiet
from sim.spatial.control.kernel.steering import Fleet
from sim.spatial.control.kernel.views import fleet_of
from sim.spatial.sites import Sites
from sim.states import DRIVING, IDLE, WAITING, WORKING, shown_states
from tests.worlds import (
    ROOM,
    SHELF,
    SITE,
    at,
    full_site,
    give,
    orca_world,
    service,
    site_crowd,
    slot,
    waypoints,
)

# the settings' defaults (sim.scenario), under the names these tests use
EXIT_M = QueueSpec().exit_m
HOLD_MAX_S = QueueSpec().hold_max_s
PULL_GAP_M = MakeWaySpec().pull_gap_m
QUEUE_M = QueueSpec().queue_m
SLOT_GAP_M = QueueSpec().slot_gap_m
OUT_M = QUEUE_M + EXIT_M  # a robot that drives out ends this far from the site


class Counter:
    """Stands in for ``Jobs.refresh``: counts the calls."""

    def __init__(self) -> None:
        self.calls = 0

    def __call__(self) -> None:
        self.calls += 1


def spy(jobs) -> Counter:
    count = Counter()
    jobs.sites.refresh = count
    return count


def _queue_state(sites: Sites) -> dict:
    f = sites.fleet
    out = {f"fleet.{k}": v for k, v in f.state_arrays().items()}
    out |= {f"sites.{k}": v for k, v in sites.state_arrays().items()}
    out |= {"blocked": sites.blocked.copy(), "held": sites.held.copy()}
    out |= {"points": sites.follower.points.copy(), "last": sites.follower.last.copy()}
    return out


@pytest.fixture(autouse=True)
def compiled_quiet_test_agrees(monkeypatch):
    """Every ``Sites.queue`` call below is also put to the compiled control period's quiet test
    (``sim.spatial.control.kernel.quiet.queue_next``): where it says the queue has nothing to
    do but set its next check, the call must change nothing else and set the time the control
    period would (now, never, or ``Sites.later_check_s``)."""
    inner = Sites.queue

    def queue(self, t):
        f, rules = self.fleet, self.rules
        sites = compiled_quiet.Sites(
            queue_m=float(rules.queue_m), crowd_m=float(rules.crowd_m),
            tol_m=0.0, zone_m=0.0, room_m=0.0,  # the arrival test's, not read by the queue's
            site=f.site, service=self.service, admitted=self.admitted, holding=self.holding,
            slotted=self.slotted, blocked=self.blocked, held=self.held, broken=self.broken,
            replan=f.replan, stuck_timeout_s=0.0,  # the stuck test's, not read
        )  # fmt: skip
        kind = compiled_quiet.queue_next(t, Fleet(*fleet_of(f)), sites)
        before = None if kind == compiled_quiet.ACTS else _queue_state(self)
        if kind == compiled_quiet.LATER:
            nxt = self.later_check_s(t)
        else:
            nxt = {compiled_quiet.NOW: t, compiled_quiet.NEVER: np.inf}.get(kind)
        inner(self, t)
        if before is not None:
            assert self.queue_check_s == nxt
            before["sites.queue_check_s"] = np.array(nxt)
            after = _queue_state(self)
            for key in before:
                assert np.array_equal(before[key], after[key]), f"{key} changed in a quiet queue"

    monkeypatch.setattr(Sites, "queue", queue)


def turn_deg(site: complex, z: complex, end: complex) -> float:
    """How far (degrees, signed) the way out to ``end`` is turned from straight away from
    ``site`` through ``z``."""
    return float(np.degrees(np.angle((end - site) / (z - site))))


def test_site_state_round_trips_through_npz_without_pickle():
    """Every array the queue keeps comes back as it was, with its type, from a file loaded
    with ``allow_pickle=False``; robot 0 was never given a task (its fields as built)."""
    _, _, jobs = site_crowd(3)
    s = jobs.sites
    s.slotted[2], s.admitted[1], s.admitted[2] = True, True, True
    s.service[3] = 4 + 2j
    s.holding[3], s.hold_since_s[3] = True, 12.5
    s.queue_check_s = 17.25
    buf = io.BytesIO()
    np.savez(buf, **s.state_arrays())
    buf.seek(0)
    with np.load(buf, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    fresh = site_crowd(3)[2].sites
    fresh.restore_arrays(arrays)
    for name, dtype in [
        ("slotted", bool),
        ("service", complex),
        ("admitted", bool),
        ("holding", bool),
        ("hold_since_s", float),
    ]:
        got, want = getattr(fresh, name), getattr(s, name)
        assert got.dtype == dtype and np.array_equal(got, want), name
    assert fresh.hold_since_s.tolist() == [np.inf, np.inf, np.inf, 12.5]
    assert fresh.queue_check_s == 17.25 and isinstance(fresh.queue_check_s, float)


def test_a_checkpoint_from_before_site_queues_restores_nobody_queued():
    """Only ``slotted`` was written then: each robot's service point is its site, nobody is
    let in or holds, and the arrays have the types :meth:`Sites.queue` needs."""
    w, f, jobs = site_crowd(2)
    f.site[1] = slot(SITE, 1)  # robot 1 went to a slot
    s = jobs.sites
    s.restore_arrays({"slotted": np.array([False, True, False])})
    assert s.slotted.tolist() == [False, True, False]
    assert s.service.dtype == complex and np.array_equal(s.service, f.site)
    for name in ("admitted", "holding"):
        got = getattr(s, name)
        assert got.dtype == bool and got.tolist() == [False] * 3, name
    assert s.hold_since_s.dtype == float and s.hold_since_s.tolist() == [np.inf] * 3
    s.queue(at(w, 3.0))  # and the queue runs on them: both robots are far off, none held
    assert not (s.admitted | s.holding).any()


def test_a_new_task_ends_any_hold_and_any_place():
    w = orca_world([(18.0, 1.0), (2.0, 9.0)])
    s = w.jobs.sites  # left over from a task that ended (release keeps the hold time)
    s.holding[1], s.hold_since_s[1], s.slotted[1], s.admitted[1] = True, 4.0, True, True
    give(w, [1], [(12.0, 2.0)])
    assert (s.holding[1], s.slotted[1], s.admitted[1]) == (False, False, False)
    assert s.hold_since_s[1] == np.inf and s.service[1] == 12 + 2j


def test_let_in_marks_the_robot_and_says_whether_its_path_changed():
    w, f, jobs = site_crowd(3)
    s = jobs.sites
    t = at(w, 10.0)
    f.last_z_m[1:4] = [SITE - 2.0, SITE + 2.0, SITE + 2.0j]
    # to the service point it already drives to: let in, nothing else changes
    assert s.let_in(1, complex(SITE), t) is False
    assert s.admitted[1] and not s.slotted[1] and f.site[1] == SITE
    # to a slot: a new path there, and the schedule looks at the sites next period
    w.schedule.site_check_s = 50.0
    place = slot(SITE, 0)
    assert s.let_in(2, place, t) is True
    assert s.admitted[2] and s.slotted[2] and f.site[2] == place
    assert waypoints(w, 2).tolist() == [SITE + 2.0, place]
    assert (f.progress_m[2], f.t_progress_s[2]) == (np.inf, t)
    assert w.schedule.site_check_s == -np.inf
    # a robot that held is let in even to its own point: it stops holding, and its path changes
    s.holding[3], s.hold_since_s[3] = True, 4.0
    deadline = f.deadline_s[3]
    assert s.let_in(3, complex(SITE), t) is True
    assert s.admitted[3] and not s.holding[3] and s.hold_since_s[3] == np.inf
    assert not s.slotted[3]
    assert f.deadline_s[3] == deadline + (t - 4.0) - HOLD_MAX_S


def test_a_robot_standing_near_the_service_point_takes_it_and_the_nearest_free_slot_is_given():
    """Robot 1 idles 0.5 m above the service point (closer than 2 radii + SLOT_GAP_M / 2 =
    0.675 m), which takes the point and slot 1 (0.35 m from it); robot 0 comes from the right
    and is given slot 0 (10.85, 5), the free one nearest to it."""
    w = orca_world([(12.4, 5.0), (10.0, 5.5)])
    f = w.fleet
    give(w, [0], [(10.0, 5.0)])
    f.last_z_m[:2] = [12.4 + 5j, 10 + 5.5j]
    assert f.state[1] == IDLE
    assert w.jobs.sites.free_place(0) == slot(SITE, 0)
    f.last_z_m[0] = 7.6 + 5j  # from the left: slot 2
    assert w.jobs.sites.free_place(0) == slot(SITE, 2)
    f.last_z_m[1] = 10 + 5j + 2 * 0.25 + 0.5 * SLOT_GAP_M  # 0.675 m off: takes nothing but slot 0
    f.last_z_m[0] = 12.4 + 5j
    assert w.jobs.sites.free_place(0) == SITE


@pytest.mark.parametrize("off_m, given", [(0.3, 1), (0.7, 0)])
def test_a_place_kept_for_a_site_close_by_takes_the_slots_it_overlaps(off_m, given):
    """Robot 3 keeps SITE's service point; robot 2, still driving far off, is let in to a site
    ``off_m`` right of SITE's slot 0. Closer than 0.675 m, its place takes slot 0 (two robots
    there would overlap), and robot 1, coming from the right and a little above, is given slot
    1 instead; 0.7 m off it takes nothing and slot 0, the nearest, is given."""
    _, f, jobs = site_crowd(3)
    s = jobs.sites
    f.site[3] = s.service[3] = SITE
    other = slot(SITE, 0) + off_m
    f.site[2] = s.service[2] = other
    s.admitted[2:4] = True
    f.last_z_m[1] = SITE + 2.0 + 0.5j
    assert s.free_place(1) == slot(SITE, given)


def test_only_a_holder_for_the_same_site_draws_a_crowd_even_half_a_metre_off():
    w, _, jobs = full_site(SITE + QUEUE_M + 0.3)
    jobs.sites.service[7] = SITE + 0.5  # robot 7 holds beside robot 6 for a site 0.5 m off
    jobs.sites.queue(at(w, 4.0))
    assert not jobs.sites.holding[6] and not jobs.sites.admitted[6]
    w, _, jobs = full_site(SITE + QUEUE_M + 0.3)
    jobs.sites.service[7] = SITE  # the same beside a holder for its own site: it holds
    jobs.sites.queue(at(w, 4.0))
    assert jobs.sites.holding[6]


def test_the_next_queue_check_looks_only_at_driving_robots():
    """Robot 2 stands idle 3 m from the site of its last task: it comes nowhere, so the next
    check is still when robot 1, 10 m off, could be within QUEUE_M."""
    w, f, jobs = site_crowd(2)
    f.state[2] = IDLE
    f.last_z_m[1:3] = [SITE + 10.0, SITE - 3.0]
    t = at(w, 3.0)
    jobs.sites.queue(t)
    v = 1.25 * w.follower.v_max_mps
    assert jobs.sites.queue_check_s == pytest.approx(t + (10.0 - QUEUE_M) / v, abs=0.2)


def test_nobody_is_sent_out_for_a_robot_at_work_or_one_not_yet_let_in():
    """Robot 1 works on the service point (let in), robot 2 drives in 3.5 m off (beyond
    QUEUE_M: not yet let in), robot 0 idles 1 m beside the site: it stays, until robot 2 is
    let in."""
    w, f, jobs = site_crowd(2)
    jobs.sites.admitted[1] = True
    f.state[1] = WORKING
    f.last_z_m[:3] = [SITE - 1.0, SITE, SITE + 3.5]
    jobs.sites.queue(at(w, 4.0))
    assert not f.yielding[0] and w.follower.last[0] == -1
    f.last_z_m[2] = SITE + 2.0
    jobs.sites.queue(at(w, 5.0))
    assert jobs.sites.admitted[2] and f.yielding[0]


def test_the_queue_refreshes_the_schedule_once_after_it_changes_paths_and_never_without():
    w, f, jobs = site_crowd(7)
    count = spy(jobs)
    f.last_z_m[1:8] = SITE + 2.0 * np.exp(1j * np.linspace(0.1, 3.0, 7))
    jobs.sites.queue(at(w, 12.0))  # robots let in (new paths) and robots that hold
    assert jobs.sites.holding.sum() == 2 and count.calls == 1
    jobs.sites.queue(at(w, 12.1))  # the same again: nobody changes
    assert count.calls == 1


def test_a_path_changed_early_in_the_queue_is_refreshed_even_if_the_last_robot_keeps_its_own():
    """Robot 1 works on the service point; robot 3 held first and is let in to the slot
    nearest it (a new path); robot 2 then gets the slot it already drives to (no new path)."""
    w, f, jobs = site_crowd(3)
    s = jobs.sites
    f.state[1] = WORKING
    f.site[2], s.slotted[2] = slot(SITE, 0), True
    s.holding[3], s.hold_since_s[3] = True, 2.0
    f.last_z_m[1:4] = [SITE, SITE + 1.5, SITE - 2.0]
    count = spy(jobs)
    s.queue(at(w, 6.0))
    assert f.site[3] == slot(SITE, 2) and f.site[2] == slot(SITE, 0)
    assert s.admitted[2] and s.admitted[3] and count.calls == 1


def test_loiterers_sent_out_are_refreshed_even_if_the_last_one_cannot_leave():
    """Idle robot 0 stands 2 m below the site and drives out; idle robot 5 on the service
    point is hemmed in by the four robots let in round it and stays: one refresh."""
    _, f, jobs = site_crowd(5)
    s = jobs.sites
    s.admitted[1:5] = True
    f.state[5] = IDLE
    f.last_z_m[:6] = [SITE - 2.0j, *(SITE + 0.55 * np.exp(0.5j * np.pi * np.arange(4))), SITE]
    count = spy(jobs)
    coming = np.zeros(6, dtype=bool)
    coming[1:5] = True
    s.clear_loiterers(coming, 9.0)
    assert f.yielding.tolist() == [True, False, False, False, False, False]
    assert count.calls == 1
    f.yielding[0] = False
    f.last_z_m[0] = SITE + 10.0  # nobody near enough to leave: no refresh
    s.clear_loiterers(coming, 9.5)
    assert count.calls == 1


def test_a_robot_holding_in_the_queue_takes_no_slot_the_queue_decides():
    w = orca_world([(4.0, 5.0), (10.0, 5.0)])
    f = w.fleet
    service(w, 8.5 + 5.2j)
    w.jobs.sites.holding[0] = True
    w.jobs.sites.take_slots([0], f.last_z_m, 5.0)
    assert f.site[0] == SITE and not w.jobs.sites.slotted[0]


@pytest.mark.parametrize("first", ["slotted", "free site"])
def test_each_robot_asking_for_a_slot_is_looked_at_whatever_the_one_before(first):
    """Robot 0 needs no slot (it has one; or its own service point is free), robot 2 finds
    robot 1 at work on its service point: it gets slot 2."""
    w = orca_world([(4.0, 5.0), (10.0, 5.0), (8.5, 5.2)])
    f, s = w.fleet, w.jobs.sites
    if first == "slotted":
        service(w, 8.3 + 4.8j)
        s.slotted[0] = True
    else:
        give(w, [0], [(16.0, 5.0)])
        f.last_z_m[:2] = [15.0 + 5j, SITE]
        f.state[1] = WORKING
    give(w, [2], [(10.0, 5.0)])
    f.last_z_m[2] = 8.5 + 5.2j
    s.take_slots([0, 2], f.last_z_m, 5.0)
    assert f.site[2] == slot(SITE, 2) and s.slotted[2]


def leaver(n: int = 2):
    """site_crowd(n): robot 0 finished 0.5 m above SITE, robot 1 (let in) comes from 3 m left;
    robots 2.. stand idle where a test puts them."""
    w, f, jobs = site_crowd(n)
    jobs.sites.admitted[1] = True
    f.state[2:] = IDLE
    f.last_z_m[:2] = [SITE + 0.5j, SITE - 3.0]
    jobs.sites.service[0] = SITE
    return w, f, jobs


def test_a_robot_on_the_service_point_itself_leaves_the_way_it_came():
    """Exactly on the point there is no 'away from the site': it drives out behind itself."""
    w, f, jobs = leaver()
    f.last_z_m[0] = SITE
    w.motors.bodies[0].angle = 0.3
    f.last_z_m[1] = SITE + 3.0j  # comes from above; the way back, down-left, is clear
    assert jobs.sites.leave(0, 9.0) is True
    assert abs(waypoints(w, 0)[-1] - (SITE - OUT_M * np.exp(0.3j))) < 1e-9


@pytest.mark.parametrize(("ahead_m", "turn"), [(1.8, 60.0), (1.3, 90.0)])
def test_the_way_out_turns_in_steps_of_30_degrees_to_the_least_turned_clear_line(ahead_m, turn):
    """Robot 2 stands ``ahead_m`` straight above the leaving robot: a line turned by theta
    passes it at ahead_m x sin(theta). At 1.8 m the 60-degree lines are the first to clear
    two reaches (1.2 m; 30 degrees: 0.9 m); at 1.3 m the 90-degree ones (60: 1.13 m), and the
    one to the left passes 0.5 m from robot 1 coming in: it leaves to the right."""
    w, f, jobs = leaver(2)
    f.last_z_m[2] = SITE + 0.5j + ahead_m * 1j
    assert jobs.sites.leave(0, 9.0) is True
    end = waypoints(w, 0)[-1]
    assert abs(abs(end - SITE) - OUT_M) < 1e-9
    assert abs(abs(turn_deg(SITE, f.last_z_m[0], end)) - turn) < 1e-9
    if turn == 90.0:
        assert abs(end - (SITE + OUT_M)) < 1e-9


def test_lines_clearing_two_reaches_count_alike_and_the_least_turned_wins():
    """Robot 2 stands 1.4 m beside the straight way out (more than two reaches) and the line
    turned 30 degrees left passes it at 2.5 m: it still drives straight out."""
    w, f, jobs = leaver(2)
    f.last_z_m[2] = SITE + 0.5j + 1.4 + 2.5j
    assert jobs.sites.leave(0, 9.0) is True
    assert abs(waypoints(w, 0)[-1] - (SITE + OUT_M * 1j)) < 1e-9


def test_the_way_out_never_ends_off_the_free_floor():
    """The site is 1.5 m below the top wall: every end up to 60 degrees from straight up is
    off the map, so the robot leaves sideways (90 degrees) onto free floor."""
    w = orca_world([(18.0, 1.0), (10.0, 5.0)])
    f, s = w.fleet, w.jobs.sites
    top = 10 + 8.5j
    give(w, [1], [(10.0, 8.5)])
    s.admitted[1] = True
    f.last_z_m[:2] = [top + 0.5j, top - 3.5j]
    s.service[0] = top
    assert s.leave(0, 9.0) is True
    end = waypoints(w, 0)[-1]
    assert w.planner.free_one(end.real, end.imag)
    assert abs(abs(turn_deg(top, f.last_z_m[0], end)) - 90.0) < 1e-9


def test_a_broken_robot_does_not_pull_over():
    w = orca_world([(10.0, 5.1), (3.0, 3.0)], obstacles=SHELF)
    w.jobs.broken[0] = True
    assert w.jobs.sites.pull_over(0, at(w, 10.0)) is False
    assert w.follower.last[0] == -1 and not w.fleet.yielding[0]


def test_a_robot_already_close_to_the_obstacle_stays():
    """0.17 m of air to the shelf (less than PULL_GAP_M + 5 cm): it stays; 0.21 m: it pulls
    over to PULL_GAP_M."""
    w = orca_world([(10.0, 6.0 - 0.25 - 0.17), (3.0, 3.0)], obstacles=SHELF)
    assert w.jobs.sites.pull_over(0, at(w, 10.0)) is False and w.follower.last[0] == -1
    w = orca_world([(10.0, 6.0 - 0.25 - 0.21), (3.0, 3.0)], obstacles=SHELF)
    assert w.jobs.sites.pull_over(0, at(w, 10.0)) is True
    assert abs(waypoints(w, 0)[-1] - (10 + (6.0 - 0.25 - PULL_GAP_M) * 1j)) < 1e-9


def test_pulling_over_needs_the_end_on_free_floor_and_clear_of_other_robots():
    """With 0.2 m of planned clearance the end (0.15 m of air) is not on the free floor; a
    robot 1 m from the end (more than 2 radii + SLOT_GAP_M = 0.85 m) does not stop it."""
    tight = orca_world([(10.0, 5.1), (3.0, 3.0)], obstacles=SHELF, clearance_m=0.2)
    assert tight.jobs.sites.pull_over(0, at(tight, 10.0)) is False
    assert tight.follower.last[0] == -1
    w = orca_world([(10.0, 5.1), (11.0, 5.6)], obstacles=SHELF)
    assert w.jobs.sites.pull_over(0, at(w, 10.0)) is True


EXIT_M = QueueSpec().exit_m
EXIT_TIMEOUT_S = QueueSpec().exit_timeout_s
HOLD_MAX_S = QueueSpec().hold_max_s
QUEUE_M = QueueSpec().queue_m
RING = 2 * 0.25 + 0.35  # m, the 4 service slots round a service point


def test_every_place_is_a_service_point_or_a_free_slot_and_counted_once():
    w = orca_world([(2.0, 2.0)], obstacles=[((10.5, 4.5), (11.5, 4.5), (11.5, 5.5), (10.5, 5.5))])
    pts = w.jobs.sites.place_points(SITE)
    assert pts[0] == SITE
    want = [SITE + RING * np.exp(2j * np.pi * k / 4) for k in (1, 2, 3)]  # slot 0 in the post
    assert np.abs(pts[1:] - np.array(want)).max() < 1e-12
    assert w.jobs.sites.place_points(SITE) is pts  # cached


def test_a_full_site_lets_in_as_many_as_it_has_places_and_the_rest_hold_waiting():
    w, f, jobs = site_crowd(7)
    t = at(w, 12.0)
    f.last_z_m[1:8] = SITE + 2.0 * np.exp(1j * np.linspace(0.1, 3.0, 7))  # all within QUEUE_M
    jobs.sites.queue(t)
    assert jobs.sites.admitted[1:8].sum() == 5 and jobs.sites.holding[1:8].sum() == 2
    assert not (jobs.sites.admitted & jobs.sites.holding).any()
    places = f.site[jobs.sites.admitted]
    assert len(set(places.tolist())) == 5  # every robot let in has a place of its own
    assert np.abs(places - SITE).max() <= RING + 1e-12
    held = jobs.sites.holding.nonzero()[0]
    for j in held:  # holds where it stands; stuck clock stopped: drawn as waiting
        assert waypoints(w, j).tolist() == [f.last_z_m[j]] * 2
        assert f.t_progress_s[j] == np.inf and f.progress_m[j] == -np.inf
        assert jobs.sites.hold_since_s[j] == t
    assert jobs.sites.queue_check_s == t  # robots near: look again next period
    shown = shown_states(f.state, f.t_progress_s, t)
    assert (shown[held] == WAITING).all() and (shown[jobs.sites.admitted] == DRIVING).all()


def test_first_come_first_served_and_the_deadline_moves_on_by_the_hold():
    w, f, jobs = site_crowd(7)
    f.last_z_m[1:8] = SITE + 2.0 * np.exp(1j * np.linspace(0.1, 3.0, 7))
    deadline = f.deadline_s.copy()
    jobs.sites.queue(at(w, 12.0))
    held = jobs.sites.holding.nonzero()[0].tolist()
    for j in held:  # while it holds, its task does not time out for HOLD_MAX_S more
        assert f.deadline_s[j] == deadline[j] + HOLD_MAX_S
    jobs.sites.hold_since_s[held[1]] = 11.0  # held[1] came first
    one = jobs.sites.admitted.nonzero()[0][0]
    jobs.finish(int(one), 20.0, True)  # a place frees
    jobs.sites.queue(at(w, 20.0))
    assert jobs.sites.admitted[held[1]] and jobs.sites.holding[held[0]]
    moved_on = (deadline[held[1]] + HOLD_MAX_S) + ((20.0 - 11.0) - HOLD_MAX_S)  # held 11 to 20
    assert f.deadline_s[held[1]] == moved_on
    assert f.deadline_s[held[0]] == deadline[held[0]] + HOLD_MAX_S
    assert np.isinf(jobs.sites.hold_since_s[held[1]]) and f.t_progress_s[held[1]] == 20.0
    assert waypoints(w, held[1])[-1] == f.site[held[1]]


def test_a_robot_beside_the_crowd_holds_too_and_far_ones_are_checked_later():
    w, f, jobs = site_crowd(7)
    f.last_z_m[1:7] = SITE + 2.0 * np.exp(1j * np.linspace(0.1, 3.0, 6))
    f.last_z_m[7] = SITE + 8.0
    jobs.sites.queue(at(w, 5.0))
    hold = jobs.sites.holding.nonzero()[0]
    assert len(hold) == 1 and not jobs.sites.admitted[7]
    f.last_z_m[7] = f.last_z_m[hold[0]] + 0.99 * np.exp(1j * np.angle(f.last_z_m[hold[0]] - SITE))
    assert abs(f.last_z_m[7] - SITE) >= QUEUE_M
    jobs.sites.queue(at(w, 6.0))
    assert jobs.sites.holding[7]  # joins the crowd of its site beyond QUEUE_M


def test_the_next_queue_check_is_when_the_nearest_robot_could_reach_queue_distance():
    w, f, jobs = site_crowd(1)
    f.last_z_m[1] = SITE + 10.0
    t = at(w, 3.0)
    jobs.sites.queue(t)
    assert not jobs.sites.admitted[1] and not jobs.sites.holding[1]
    v = 1.25 * w.follower.v_max_mps
    assert jobs.sites.queue_check_s == pytest.approx(t + (10.0 - QUEUE_M) / v, abs=0.2)


def segment_clearance(a: complex, b: complex, pts: np.ndarray) -> float:
    u = np.clip(((pts - a) * np.conj(b - a)).real / abs(b - a) ** 2, 0.0, 1.0)
    return float(np.abs(pts - (a + u * (b - a))).min())


def test_a_robot_that_finished_drives_out_through_the_widest_gap_in_the_queue():
    w, f, jobs = site_crowd(7)
    f.last_z_m[1:8] = SITE + 2.0 * np.exp(1j * np.linspace(0.1, 3.0, 7))  # the upper half
    jobs.sites.queue(at(w, 5.0))
    j = int(jobs.sites.admitted.nonzero()[0][0])
    f.last_z_m[j] = SITE + 0.5j  # finishing just above the service point
    jobs.finish(j, 9.0, True)
    assert f.state[j] == IDLE and f.yielding[j] and f.yield_until_s[j] == 9.0 + EXIT_TIMEOUT_S
    end = waypoints(w, j)[-1]
    assert abs(abs(end - SITE) - (QUEUE_M + EXIT_M)) < 1e-9
    others = np.delete(f.last_z_m, j)
    others = others[np.abs(others - f.last_z_m[j]) < QUEUE_M + EXIT_M]
    assert segment_clearance(f.last_z_m[j], end, others) >= 2 * w.reach_m_  # not through them
    assert end.imag < SITE.imag  # the crowd stands above: it leaves below


def test_with_nobody_in_the_way_a_robot_drives_straight_out():
    w, f, jobs = site_crowd(1)
    f.last_z_m[1] = SITE - 3.0  # comes from the left
    jobs.sites.admitted[1] = True
    f.last_z_m[0] = SITE + 0.5j
    jobs.sites.service[0] = SITE
    assert jobs.sites.leave(0, 9.0) is True
    assert abs(waypoints(w, 0)[-1] - (SITE + (QUEUE_M + EXIT_M) * 1j)) < 1e-9


def test_nobody_coming_nobody_drives_out():
    w, f, jobs = site_crowd(1)
    f.last_z_m[1] = SITE
    jobs.finish(1, 9.0, True)
    assert not f.yielding[1] and w.follower.last[1] == -1


def test_idle_robots_loitering_at_a_site_robots_are_let_in_to_drive_out():
    w = orca_world([(10.0, 5.0), (2.0, 5.0), (10.0, 6.0), (16.0, 2.0)])
    f, jobs = w.fleet, w.jobs
    give(w, [1], [(10.0, 5.0)])
    f.last_z_m[1] = SITE - 2.0
    f.last_z_m[3] = 16 + 2j  # far: stays
    jobs.sites.queue(at(w, 4.0))
    assert jobs.sites.admitted[1]
    assert f.yielding.tolist() == [True, False, True, False]  # 0 on the point, 2 beside it
    assert abs(waypoints(w, 2)[-1] - (SITE + (QUEUE_M + EXIT_M) * 1j)) < 1e-9


@pytest.mark.parametrize("off_m, leaves", [(QUEUE_M - 1e-6, True), (QUEUE_M, False)])
def test_an_idle_robot_just_within_queue_distance_of_a_site_robots_come_to_drives_out(
    off_m, leaves
):
    """``Sites.clear_loiterers`` sends out an idle robot closer than ``queue_m`` to the site,
    however close to that bound, and not one at it."""
    w = orca_world([(10.0, 9.0), (2.0, 5.0), (10.0, 5.0 - off_m)])
    f, jobs = w.fleet, w.jobs
    give(w, [1], [(10.0, 5.0)])
    f.last_z_m[1] = SITE - 2.0
    f.last_z_m[2] = SITE - off_m * 1j
    jobs.sites.queue(at(w, 4.0))
    assert jobs.sites.admitted[1]
    assert f.yielding.tolist() == [False, False, leaves]


def test_a_leaving_robot_never_heads_straight_at_a_robot_let_in_and_else_stays():
    w, f, jobs = site_crowd(1)
    jobs.sites.admitted[1] = True
    f.last_z_m[0], jobs.sites.service[0] = SITE + 0.5j, SITE
    f.last_z_m[1] = SITE + 2.0j  # driving in from straight above
    assert jobs.sites.leave(0, 9.0) is True
    end = waypoints(w, 0)[-1]
    assert abs(end - (SITE + (QUEUE_M + EXIT_M) * 1j)) > 1.0  # not straight up at it ...
    assert segment_clearance(f.last_z_m[0], end, f.last_z_m[1:2]) >= w.reach_m_  # ... clear
    # hemmed in: an admitted robot close on every side of the 11 lines -> it stays
    _, f2, jobs2 = site_crowd(4)
    jobs2.sites.admitted[1:5] = True
    f2.last_z_m[0], jobs2.sites.service[0] = SITE, SITE
    f2.last_z_m[1:5] = SITE + 0.55 * np.exp(1j * np.pi * np.array([0.0, 0.5, 1.0, 1.5]))
    f2.yielding[0] = False
    assert jobs2.sites.leave(0, 9.0) is False and not f2.yielding[0]


def test_idle_robots_on_every_place_are_sent_out_for_a_robot_holding_in_the_queue():
    """Five idle robots stand on the service point and the four slots: nobody can be let in,
    so robot 5 holds, and the idle robots are asked to leave for it (before, with no robot let
    in, nobody asked them and the queue waited for ever)."""
    places = [SITE + (RING * np.exp(1j * np.pi / 2 * k) if k else 0) for k in range(5)]
    starts = [(p.real, p.imag) for p in places] + [(10.0, 8.0)]
    w = orca_world(starts)
    f, jobs = w.fleet, w.jobs
    give(w, [5], [(10.0, 5.0)])
    f.last_z_m[:] = np.array([*places, 10 + 7.0j])
    jobs.sites.queue(at(w, 4.0))
    assert jobs.sites.holding[5] and not jobs.sites.admitted[5]
    assert f.yielding[:5].any()  # asked to drive out


def test_exactly_queue_distance_off_is_not_near_and_a_crowd_of_another_site_is_no_queue():
    w, f, jobs = full_site(SITE + QUEUE_M)  # 12.5 + 5j: exactly QUEUE_M from (10, 5)
    assert abs(f.last_z_m[6] - SITE) == QUEUE_M
    jobs.sites.queue(at(w, 4.0))
    assert not jobs.sites.holding[6] and not jobs.sites.admitted[6]  # beside 7, who holds elsewhere
    f.last_z_m[6] = SITE + QUEUE_M - 1e-9
    jobs.sites.queue(at(w, 5.0))
    assert jobs.sites.holding[6]


def test_a_robot_whose_back_off_ends_now_is_let_in_and_one_still_backing_off_is_not():
    w, f, jobs = site_crowd(1)
    f.last_z_m[1] = SITE - 1.0
    t = at(w, 6.0)
    f.backoff_until_s[1] = t + 0.1
    jobs.sites.queue(t)
    assert not jobs.sites.admitted[1]
    f.backoff_until_s[1] = t
    jobs.sites.queue(t)
    assert jobs.sites.admitted[1]


def test_leave_needs_the_robot_near_the_site_not_broken_and_someone_coming():
    _, f, jobs = site_crowd(1)
    jobs.sites.admitted[1] = True
    f.last_z_m[1] = SITE - 3.0
    jobs.sites.service[0] = SITE
    f.last_z_m[0] = SITE + QUEUE_M * 1j  # exactly QUEUE_M off: not near
    assert jobs.sites.leave(0, 9.0) is False
    f.last_z_m[0] = SITE + 0.5j
    jobs.broken[0] = True
    assert jobs.sites.leave(0, 9.0) is False
    jobs.broken[0] = False
    f.state[1] = IDLE  # nobody comes
    assert jobs.sites.leave(0, 9.0) is False
    assert not f.yielding[0]


def test_clearance_measures_to_the_segment_not_the_line_beyond_it():
    from sim.spatial.sites import Sites

    ends = np.array([4.0 + 0j])
    others = np.array([7.0 + 4.0j, 2.0 - 1.0j])  # 5 m beyond the end; 1 m beside the middle
    got = Sites.clearance(0j, ends, others)
    assert got.tolist() == [1.0]
    assert Sites.clearance(0j, ends, others[:1]).tolist() == [5.0]
    assert Sites.clearance(0j, ends, np.zeros(0, dtype=complex)).tolist() == [np.inf]


SLOT_GAP_M = QueueSpec().slot_gap_m
YIELD_TIMEOUT_S = MakeWaySpec().timeout_s


def test_an_idle_robot_in_a_narrow_place_pulls_over_to_the_nearest_obstacle():
    """Body 0.65 m from the shelf face (< PULL_ROOM_M): it drives toward it and stops with
    PULL_GAP_M of air (centre at 6 - 0.25 - 0.15 = 5.6 m), yielding meanwhile; one in the
    open and one whose end point another robot stands near stay."""
    w = orca_world([(10.0, 5.1), (3.0, 3.0)], obstacles=SHELF)
    f = w.fleet
    t = at(w, 10.0)
    assert w.jobs.sites.pull_over(0, t)
    assert abs(waypoints(w, 0)[-1] - (10.0 + 5.6j)) < 1e-9
    assert f.yielding[0] and f.yield_until_s[0] == t + YIELD_TIMEOUT_S
    assert not w.jobs.sites.pull_over(1, t) and not f.yielding[1]
    w2 = orca_world([(10.0, 5.1), (10.6, 5.6)], obstacles=SHELF)
    assert not w2.jobs.sites.pull_over(0, t) and w2.follower.last[0] == -1


def test_newcomer_takes_the_nearest_free_service_slot_beside_a_robot_at_work():
    w = orca_world([(4.0, 5.0), (10.0, 5.0)])
    f, jobs = w.fleet, w.jobs
    service(w, 8.5 + 5.2j)
    w.schedule.resting = True
    t = at(w, 12.0)
    jobs.sites.take_slots([0], f.last_z_m, t)
    k3 = slot(10 + 5j, 2)
    assert abs(k3 - (9.15 + 5j)) < 1e-12
    assert f.site[0] == k3
    assert jobs.sites.slotted.tolist() == [True, False]
    assert waypoints(w, 0).tolist() == [8.5 + 5.2j, k3]
    assert (f.progress_m[0], f.t_progress_s[0]) == (np.inf, t)
    assert w.schedule.resting is False
    w.schedule.resting = True
    jobs.sites.take_slots([0], f.last_z_m, t)  # a slot already: nothing changes
    assert f.site[0] == k3 and w.schedule.resting is True


def test_a_robot_waiting_for_a_repair_that_gets_a_slot_waits_no_more():
    """Robot 0 waits near its site for a repair (``Jobs.wait_for_repair``: broken robots
    close its way) while robot 1 works on the service point: given a free slot it drives
    there, and is no longer waiting."""
    w = orca_world([(4.0, 5.0), (10.0, 5.0)])
    f, jobs = w.fleet, w.jobs
    service(w, 8.5 + 5.2j)
    jobs.blocked[0] = True
    jobs.sites.take_slots([0], f.last_z_m, at(w, 12.0))
    assert f.site[0] == slot(10 + 5j, 2) and jobs.sites.slotted[0]
    assert jobs.blocked.tolist() == [False, False]


def test_slots_in_an_obstacle_near_a_standing_robot_or_another_robots_goal_are_not_taken():
    post = [((8.7, 4.8), (9.1, 4.8), (9.1, 5.2), (8.7, 5.2))]  # grown by 0.35 m: covers slot 2
    w = orca_world([(4.0, 5.6), (10.0, 5.0), (12.0, 8.0), (14.0, 8.0)], obstacles=post)
    f = w.fleet
    site = 10 + 5j
    service(w, 8.5 + 5.6j)
    f.last_z_m[3] = slot(site, 1) + 0.674j  # just too close to slot 1
    give(w, [2], [(12.0, 2.0)])
    f.site[2] = slot(site, 3)  # robot 2 drives to slot 3
    w.jobs.sites.take_slots([0], f.last_z_m, 5.0)
    assert f.site[0] == slot(site, 0)  # nearest to (8.5, 5.6): 2, 1, 3, then 0
    assert waypoints(w, 0)[-1] == slot(site, 0)


def test_with_no_free_slot_the_newcomer_waits_where_it_is():
    ring = [slot(10 + 5j, k) for k in range(4)]
    starts = [(4.0, 5.0), (10.0, 5.0)] + [(p.real, p.imag) for p in ring]
    w = orca_world(starts)
    f = w.fleet
    service(w, 8.5 + 5.2j)
    f.last_z_m[2:] = ring
    w.schedule.resting = True
    w.jobs.sites.take_slots([0], f.last_z_m, 5.0)
    assert f.site[0] == 10 + 5j and w.jobs.sites.slotted[0] == False  # noqa: E712
    assert waypoints(w, 0).tolist() == [4 + 5j, 10 + 5j]
    assert w.schedule.resting is True


def test_newcomer_keeps_its_site_while_the_service_point_is_free():
    w = orca_world([(4.0, 1.0), (10.0, 1.675), (10.0, 0.6)])
    f = w.fleet
    give(w, [0, 2], [(10.0, 1.0), (16.0, 0.6)])
    f.state[1] = WORKING  # 2 radii + SLOT_GAP_M / 2 from the site: not on it
    f.last_z_m[:3] = [8.5 + 1j, 10 + 1.675j, 10 + 0.6j]  # robot 2 drives: not standing
    assert abs(f.last_z_m[1] - f.site[0]) == 2 * 0.25 + 0.5 * 0.35
    w.schedule.resting = True
    w.jobs.sites.take_slots([0], f.last_z_m, 5.0)
    assert f.site[0] == 10 + 1j and w.jobs.sites.slotted[0] == False  # noqa: E712
    assert w.schedule.resting is True


def test_idle_robot_on_the_service_point_steps_clear_of_the_newcomer():
    w = orca_world([(4.0, 5.0), (10.0, 5.0)])
    f = w.fleet
    service(w, 8.5 + 5.0j, on_site_state=IDLE)
    w.motors.bodies[1].angle = np.pi / 2  # it faces +y: steps to its left, -x
    t = at(w, 6.0)
    w.jobs.sites.take_slots([0], f.last_z_m, t)
    assert f.yielding.tolist() == [False, True]
    assert f.yield_until_s[1] == t + YIELD_TIMEOUT_S
    path = waypoints(w, 1)
    assert path[0] == 10 + 5j and abs(path[1] - (9 + 5j)) < 1e-12
    assert f.site[0] == 10 + 5j and w.jobs.sites.slotted[0] == False  # noqa: E712
    assert (w.schedule.n_yield, w.schedule.steer_list) == (1, [0, 1])


def test_step_clear_takes_the_free_side_and_a_robot_with_none_stays():
    w = orca_world([(10.0, 5.0), (10.0, 6.0), (14.0, 5.0), (14.0, 6.0), (14.0, 4.0), (15.0, 5.0)])
    f = w.fleet
    for b in w.motors.bodies:
        b.angle = 0.0
    w.jobs.sites.step_clear([0, 2], 3.0)  # robot 1 stands on 0's left; 3, 4, 5 round robot 2
    assert f.yielding.tolist() == [True, False, False, False, False, False]
    assert f.yield_until_s[0] == 3.0 + YIELD_TIMEOUT_S
    assert waypoints(w, 0).tolist() == [10 + 5j, 10 + 4j]
    assert w.follower.last[2] == -1


def test_an_idle_robot_on_the_point_steps_clear_even_beside_one_at_work_at_the_slot_ring():
    # the service point (10, 1); robot 2 works exactly 2 radii + SLOT_GAP_M / 2 from it
    w = orca_world([(6.0, 1.0), (10.0, 1.0), (10.0, 1.675)])
    f = w.fleet
    give(w, [0], [(10.0, 1.0)])
    f.state[1:] = [IDLE, WORKING]
    f.last_z_m[:] = [8.8 + 1j, 10 + 1j, 10 + 1.675j]
    assert abs(f.last_z_m[2] - f.site[0]) == 2 * 0.25 + 0.5 * 0.35
    w.jobs.sites.take_slots([0], f.last_z_m, 4.0)
    assert f.yielding.tolist() == [False, True, False]  # the idle one steps clear
    assert f.site[0] == 10 + 1j and w.jobs.sites.slotted[0] == False  # noqa: E712


def test_every_newcomer_in_one_call_is_answered():
    # robots 0, 1, 2 come for (4, 8), (10, 8), (16, 8): idle 3, idle 4 and working 5 stand there
    starts = [(4.0, 2.0), (10.0, 2.0), (16.0, 2.0), (4.0, 8.0), (10.0, 8.0), (16.0, 8.0)]
    w = orca_world(starts)
    f = w.fleet
    give(w, [0, 1, 2], starts[3:])
    f.state[5] = WORKING
    f.last_z_m[:3] = [4 + 7j, 10 + 7j, 15.8 + 7j]
    w.jobs.sites.take_slots([0, 1, 2], f.last_z_m, 4.0)
    assert f.yielding.tolist() == [False, False, False, True, True, False]
    assert w.jobs.sites.slotted.tolist() == [False, False, True, False, False, False]
    assert f.site[2] == slot(16 + 8j, 3)


def test_a_newcomer_without_a_free_slot_or_a_path_to_one_does_not_stop_the_next():
    pocket = [  # a 0.8 m square hole round (4, 5): its service point fits a robot, no slot does
        ((3.0, 3.0), (5.0, 3.0), (5.0, 4.6), (3.0, 4.6)),
        ((3.0, 5.4), (5.0, 5.4), (5.0, 7.0), (3.0, 7.0)),
        ((3.0, 4.6), (3.6, 4.6), (3.6, 5.4), (3.0, 5.4)),
        ((4.4, 4.6), (5.0, 4.6), (5.0, 5.4), (4.4, 5.4)),
    ]
    starts = [(2.0, 8.0), (15.0, 5.0), (15.8, 1.0), (4.0, 5.0), (10.0, 2.0), (16.0, 2.0)]
    w = orca_world(starts, obstacles=pocket + ROOM)
    f = w.fleet
    f.site[:3] = [4 + 5j, 10 + 2j, 16 + 2j]  # robots 0, 1, 2 come for the points of 3, 4, 5
    f.state[:3] = DRIVING
    f.task[:3] = [0, 1, 2]
    f.state[3:] = WORKING
    f.last_z_m[:] = [2 + 8j, 15 + 5j, 15.8 + 1j, 4 + 5j, 10 + 2j, 16 + 2j]  # 1 is walled in
    w.jobs.sites.take_slots([0, 1, 2], f.last_z_m, 4.0)
    assert w.jobs.sites.slotted.tolist() == [False, False, True, False, False, False]
    assert f.site[2] == slot(16 + 2j, 3)  # the nearest slot to (15.8, 1) ...
    assert f.site[:2].tolist() == [4 + 5j, 10 + 2j]  # ... the others keep their points


def test_a_slot_exactly_its_room_from_a_standing_robot_is_free():
    # service point (10, 1); robot 2 stands 2 radii + SLOT_GAP_M / 2 above slot 0
    w = orca_world([(12.0, 1.0), (10.0, 1.0), (10.85, 1.675)])
    f = w.fleet
    give(w, [0], [(10.0, 1.0)])
    f.state[1:] = [WORKING, IDLE]
    f.last_z_m[0] = 11.2 + 1j
    k0 = slot(10 + 1j, 0)
    assert abs(f.last_z_m[2] - k0) == 2 * 0.25 + 0.5 * 0.35
    w.jobs.sites.take_slots([0], f.last_z_m, 4.0)
    assert f.site[0] == k0


def test_a_slot_counts_as_another_robots_goal_up_to_a_micrometre_from_it():
    # service point (1, 1.5): slot 0 is (1.85, 1.5); robot 2 drives to a point exactly
    # 1e-6 m from it (offsets in units of 2^-52 m, so every difference is exact)
    w = orca_world([(3.0, 1.6), (1.0, 1.5), (4.0, 4.0)])
    f = w.fleet
    give(w, [0, 2], [(1.0, 1.5), (6.0, 4.0)])
    f.state[1] = WORKING
    k0 = slot(1.0 + 1.5j, 0)
    f.site[2] = complex(k0.real + 3979479812 * 2.0**-52, k0.imag + 2108589583 * 2.0**-52)
    assert abs(f.site[2] - k0) == 1e-6
    f.last_z_m[0] = 2.5 + 1.6j
    w.jobs.sites.take_slots([0], f.last_z_m, 4.0)
    assert f.site[0] == slot(1.0 + 1.5j, 1)  # slot 0 is robot 2's: the next nearest
    w.jobs.sites.slotted[0] = False
    f.site[0] = 1.0 + 1.5j
    f.site[2] = k0 + 2e-6  # farther: another point, slot 0 is free
    w.jobs.sites.take_slots([0], f.last_z_m, 4.0)
    assert f.site[0] == k0


def test_step_clear_skips_a_broken_robot_and_serves_the_next():
    w = orca_world([(4.0, 5.0), (10.0, 5.0)])
    for b in w.motors.bodies:
        b.angle = 0.0
    w.jobs.broken[:] = [True, False]
    w.jobs.sites.step_clear([0, 1], 3.0)  # robot 0 cannot move; robot 1 still steps clear
    assert w.fleet.yielding.tolist() == [False, True]
    assert w.follower.last[0] == -1 and len(waypoints(w, 1)) == 2


def _free_place_by_brute_force(s: Sites, j: int) -> complex | None:
    """``Sites.free_place`` as its docstring says, every robot tested against every place."""
    f, r = s.fleet, s.controller.radius_m
    cand = s.place_points(s.service[j])
    keeping = s.admitted | (f.state == WORKING)
    keeping[j] = False
    others = np.concatenate([f.site[keeping], f.last_z_m[f.state != DRIVING]])
    room = 2.0 * r + 0.5 * SLOT_GAP_M
    taken = [bool((np.abs(others - c) < room).any()) for c in cand]
    if all(taken):
        return None
    free = [k for k, t in enumerate(taken) if not t]
    if free[0] == 0:
        return complex(cand[0])
    return complex(cand[min(free, key=lambda k: abs(cand[k] - f.last_z_m[j]))])


@pytest.mark.parametrize("seed", range(6))
def test_a_free_place_is_what_testing_every_robot_against_every_place_gives(seed):
    """Twelve robots at random round SITE, some at work, idle, let in or driving, and a few
    exactly a room off one of its places, where rounding decides: ``free_place`` (which looks
    only at robots near the site) gives what testing every robot gives, for every robot."""
    rng = np.random.default_rng(seed)
    starts = [(2.0 + 1.5 * k, 9.0) for k in range(12)]
    w = orca_world(starts)
    give(w, list(range(12)), [(10.0, 5.0)] * 12)
    f, s = w.fleet, w.jobs.sites
    room = 2 * 0.25 + 0.5 * SLOT_GAP_M
    places = s.place_points(SITE)
    for trial in range(20):
        f.last_z_m[:] = SITE + rng.uniform(-2.5, 2.5, 12) + 1j * rng.uniform(-2.5, 2.5, 12)
        edge = rng.choice(12, 3, replace=False)  # a room off a place, in a random direction
        f.last_z_m[edge] = places[rng.integers(len(places), size=3)] + room * np.exp(
            2j * np.pi * rng.uniform(size=3)
        )
        f.state[:] = rng.choice([DRIVING, WORKING, IDLE], 12)
        s.admitted[:] = rng.uniform(size=12) < 0.3
        f.site[:] = np.where(s.admitted, f.last_z_m + 0.3, SITE)
        for j in range(12):
            assert s.free_place(j) == _free_place_by_brute_force(s, j), (trial, j)
