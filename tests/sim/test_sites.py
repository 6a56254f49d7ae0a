"""``sim.spatial.sites.Sites`` method by method: what each writes, what it returns, when it asks for
the schedule to be refreshed, and its checkpoint. Written for the gaps mutation run H found
(README, "Testing"); the queue as a whole is in ``test_site_queue.py``.

Geometry used throughout: robots of radius 0.25 m, reach 0.6 m (``PymunkWorld.reach_m_``),
service slots on a ring of 0.85 m round a service point, a robot standing within 0.675 m of a
place takes it.
"""

from __future__ import annotations

import io

import numpy as np
import pytest

from sim.scenario import MakeWaySpec, QueueSpec
from sim.states import IDLE, WORKING
from tests.sim.test_jobs import SHELF, at, give, orca_world, service, slot, waypoints
from tests.sim.test_site_queue import SITE, crowd, full_site

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


def turn_deg(site: complex, z: complex, end: complex) -> float:
    """How far (degrees, signed) the way out to ``end`` is turned from straight away from
    ``site`` through ``z``."""
    return float(np.degrees(np.angle((end - site) / (z - site))))


# ---- checkpoint --------------------------------------------------------------------------


def test_site_state_round_trips_through_npz_without_pickle():
    """Every array the queue keeps comes back as it was, with its type, from a file loaded
    with ``allow_pickle=False``; robot 0 was never given a task (its fields as built)."""
    _, _, jobs = crowd(3)
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
    fresh = crowd(3)[2].sites
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
    w, f, jobs = crowd(2)
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


# ---- let_in, free_place ------------------------------------------------------------------


def test_let_in_marks_the_robot_and_says_whether_its_path_changed():
    w, f, jobs = crowd(3)
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
    _, f, jobs = crowd(3)
    s = jobs.sites
    f.site[3] = s.service[3] = SITE
    other = slot(SITE, 0) + off_m
    f.site[2] = s.service[2] = other
    s.admitted[2:4] = True
    f.last_z_m[1] = SITE + 2.0 + 0.5j
    assert s.free_place(1) == slot(SITE, given)


# ---- queue ---------------------------------------------------------------------------------


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
    w, f, jobs = crowd(2)
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
    w, f, jobs = crowd(2)
    jobs.sites.admitted[1] = True
    f.state[1] = WORKING
    f.last_z_m[:3] = [SITE - 1.0, SITE, SITE + 3.5]
    jobs.sites.queue(at(w, 4.0))
    assert not f.yielding[0] and w.follower.last[0] == -1
    f.last_z_m[2] = SITE + 2.0
    jobs.sites.queue(at(w, 5.0))
    assert jobs.sites.admitted[2] and f.yielding[0]


def test_the_queue_refreshes_the_schedule_once_after_it_changes_paths_and_never_without():
    w, f, jobs = crowd(7)
    count = spy(jobs)
    f.last_z_m[1:8] = SITE + 2.0 * np.exp(1j * np.linspace(0.1, 3.0, 7))
    jobs.sites.queue(at(w, 12.0))  # robots let in (new paths) and robots that hold
    assert jobs.sites.holding.sum() == 2 and count.calls == 1
    jobs.sites.queue(at(w, 12.1))  # the same again: nobody changes
    assert count.calls == 1


def test_a_path_changed_early_in_the_queue_is_refreshed_even_if_the_last_robot_keeps_its_own():
    """Robot 1 works on the service point; robot 3 held first and is let in to the slot
    nearest it (a new path); robot 2 then gets the slot it already drives to (no new path)."""
    w, f, jobs = crowd(3)
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
    _, f, jobs = crowd(5)
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


# ---- take_slots --------------------------------------------------------------------------


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


# ---- leave ---------------------------------------------------------------------------------


def leaver(n: int = 2):
    """crowd(n): robot 0 finished 0.5 m above SITE, robot 1 (let in) comes from 3 m left;
    robots 2.. stand idle where a test puts them."""
    w, f, jobs = crowd(n)
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


# ---- pull_over -----------------------------------------------------------------------------


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
