"""Site queues and going round (``sim.spatial.jobs.Jobs`` with collision avoidance on), driven
directly as in ``test_jobs.py``: who is let in, who holds and is drawn as waiting, who drives
out, and the path round a jam (``GridPlanner.path_around``)."""

from __future__ import annotations

import numpy as np
import pytest

from scenarios.experiments.hardcases import circle, swap_world
from sim.scenario import JamSpec, QueueSpec
from sim.states import DRIVING, IDLE, WAITING, WORKING, shown_states
from tests.sim.test_jobs import at, give, make_world, orca_world, waypoints

# the settings' defaults (sim.scenario), under the names these tests use
AROUND_M = JamSpec().around_m
EXIT_M = QueueSpec().exit_m
EXIT_TIMEOUT_S = QueueSpec().exit_timeout_s
HOLD_MAX_S = QueueSpec().hold_max_s
QUEUE_M = QueueSpec().queue_m


SITE = 10 + 5j
RING = 2 * 0.25 + 0.35  # m, the 4 service slots round a service point


def crowd(n_close: int, xs=None) -> tuple:
    """A world whose robots 1..n all come for SITE (given their tasks where they stand); robot
    0 stands idle far off."""
    starts = [(18.0, 1.0)] + [(2.0 + 1.5 * k, 9.0) for k in range(n_close)]
    w = orca_world(starts)
    give(w, list(range(1, n_close + 1)), [(10.0, 5.0)] * n_close)
    return w, w.fleet, w.jobs


def test_every_place_is_a_service_point_or_a_free_slot_and_counted_once():
    w = orca_world([(2.0, 2.0)], obstacles=[((10.5, 4.5), (11.5, 4.5), (11.5, 5.5), (10.5, 5.5))])
    pts = w.jobs.sites.place_points(SITE)
    assert pts[0] == SITE
    want = [SITE + RING * np.exp(2j * np.pi * k / 4) for k in (1, 2, 3)]  # slot 0 in the post
    assert np.abs(pts[1:] - np.array(want)).max() < 1e-12
    assert w.jobs.sites.place_points(SITE) is pts  # cached


def test_a_full_site_lets_in_as_many_as_it_has_places_and_the_rest_hold_waiting():
    w, f, jobs = crowd(7)
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
    w, f, jobs = crowd(7)
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
    assert f.deadline_s[held[1]] == deadline[held[1]] + (20.0 - 11.0)
    assert f.deadline_s[held[0]] == deadline[held[0]] + HOLD_MAX_S
    assert np.isinf(jobs.sites.hold_since_s[held[1]]) and f.t_progress_s[held[1]] == 20.0
    assert waypoints(w, held[1])[-1] == f.site[held[1]]


def test_a_robot_beside_the_crowd_holds_too_and_far_ones_are_checked_later():
    w, f, jobs = crowd(7)
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
    w, f, jobs = crowd(1)
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
    w, f, jobs = crowd(7)
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
    w, f, jobs = crowd(1)
    f.last_z_m[1] = SITE - 3.0  # comes from the left
    jobs.sites.admitted[1] = True
    f.last_z_m[0] = SITE + 0.5j
    jobs.sites.service[0] = SITE
    assert jobs.sites.leave(0, 9.0) is True
    assert abs(waypoints(w, 0)[-1] - (SITE + (QUEUE_M + EXIT_M) * 1j)) < 1e-9


def test_nobody_coming_nobody_drives_out():
    w, f, jobs = crowd(1)
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


def test_holders_never_give_way_and_a_stuck_robot_goes_round_them():
    starts = [(6.0, 5.0), (8.0, 5.0)]
    w = orca_world(starts)
    f, jobs = w.fleet, w.jobs
    give(w, [0, 1], [(14.0, 5.0), (2.0, 5.0)])
    jobs.sites.holding[1] = True
    f.last_z_m[:2] = [7.4 + 5j, 8 + 5j]
    t = at(w, 30.0)
    assert jobs.jams.give_way(0, t) is False  # the only driving robot near holds: no deadlock
    jobs.recover(0, t)
    path = waypoints(w, 0)
    assert f.recoveries[0] == 1 and len(path) > 2
    seg_a, seg_b = path[:-1], path[1:]
    # every segment of the new path keeps the grown robot (an octagon round its disc) clear
    u = np.clip(((8 + 5j - seg_a) * (seg_b - seg_a).conj()).real / np.abs(seg_b - seg_a) ** 2, 0, 1)
    gap = np.abs(seg_a + u * (seg_b - seg_a) - (8 + 5j))
    assert gap[1:].min() >= 0.25 + 0.25 + 0.1 - 1e-9  # the first leaves from inside it


def test_going_round_needs_a_robot_near_a_try_left_and_a_short_enough_path(monkeypatch):
    w = orca_world([(6.0, 5.0), (6.0 + AROUND_M, 5.0)])
    f, jobs = w.fleet, w.jobs
    give(w, [0, 1], [(14.0, 5.0), (2.0, 5.0)])
    f.last_z_m[:2] = [6 + 5j, 6 + AROUND_M + 5j]  # exactly AROUND_M apart: not near
    assert jobs.jams.go_round(0, 3.0) is False
    f.last_z_m[1] = 8 + 5j
    f.recoveries[0] = w.spatial.max_recoveries
    assert jobs.jams.go_round(0, 3.0) is False
    f.recoveries[0] = 0
    f.left_m[0] = 4.0
    long = np.array([[6.0, 5.0], [6.0, 5.0 + 11.0], [6.0, 5.0]])  # 22 m = 3 x 4 + 10
    monkeypatch.setattr(w.planner, "path_around", lambda *a: long)
    assert jobs.jams.go_round(0, 3.0) is True  # exactly the limit: taken
    f.recoveries[0], jobs.jams.around_s[0] = 0, -np.inf
    long[1, 1] += 1e-6
    assert jobs.jams.go_round(0, 4.0) is False  # a hair longer: not taken
    assert f.recoveries[0] == 0


def test_no_path_round_a_robot_that_fills_the_only_lane():
    lane = [
        ((1.3, 4.5), (9.0, 4.5), (9.0, 9.0), (1.3, 9.0)),
        ((0.0, 4.3), (9.0, 4.3), (9.0, 4.5), (0.0, 4.5)),
    ]
    w = orca_world([(0.65, 5.0), (0.65, 5.7)], obstacles=lane)
    give(w, [0], [(0.65, 9.5)])
    w.fleet.last_z_m[:2] = [0.65 + 5j, 0.65 + 5.7j]
    assert w.jobs.jams.go_round(0, 3.0) is False
    assert w.fleet.recoveries[0] == 0 and waypoints(w, 0)[-1] == 0.65 + 9.5j


def test_path_around_without_robots_is_the_plain_path():
    w = make_world([(2.0, 2.0)], obstacles=[((8.0, 3.0), (12.0, 3.0), (12.0, 7.0), (8.0, 7.0))])
    pl = w.planner
    a, b = (2.0, 5.0), (18.0, 5.0)
    assert np.array_equal(pl.path_around(a, b, np.zeros(0), 0.25), pl.path(a, b))


@pytest.mark.parametrize("control", ["scalar", "array"])
def test_thirty_robots_sent_to_one_site_all_work_there_within_90_s_without_a_contact(control):
    """The issue's hard case: 30 robots on an 8 m circle all sent to its centre with 2 s of
    work each; the site's queue lets them in five at a time (measured 61-71 s)."""
    n, centre = 30, (10.0, 10.0)
    starts, _ = circle(n, 8.0, centre)
    world = swap_world(starts, [centre] * n, (20.0, 20.0), control)
    world.jobs.exec_time_s[:] = 2.0
    worked = np.zeros(n, dtype=bool)
    while world.time_s < 90.0 and not worked.all():
        world.advance(0.1)
        worked |= world.fleet.state == WORKING
    assert worked.all(), f"{int((~worked).sum())} robots never worked within 90 s"
    assert world.contacts.robot_hits == 0 and world.contacts.wall_hits == 0
    assert world.jobs.failures == 0


def test_in_a_large_arena_path_around_plans_in_a_local_box_and_finds_the_same_path():
    """More than ``local_min_vertices`` obstacle vertices: the throwaway planner keeps only the
    obstacles near the start, the goal and the robots; round one robot in open floor that
    gives the path the whole arena gives."""
    import sim.spatial.navigation.planning as planning
    from sim.scenario import DriveSpec, SpatialSpec

    boxes = tuple(
        ((x, y), (x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0))
        for x in range(5, 60, 6)
        for y in range(5, 60, 6)
    )
    sp = SpatialSpec(64.0, 64.0, boxes, (((2.0, 2.0),),), DriveSpec())
    pl = planning.GridPlanner(sp)
    assert len(pl.vertices_) > pl.local_min_vertices
    start, goal, robot = (2.5, 3.0), (9.0, 3.0), np.array([5.0 + 3.0j])
    local = pl.path_around(start, goal, robot, 0.25)
    whole = planning.GridPlanner(sp, local_min_vertices=10**9).path_around(start, goal, robot, 0.25)
    assert len(local) > 2 and np.allclose(local, whole)
    far = pl.path_around((2.5, 3.0), (62.0, 62.0), robot, 0.25)  # goal far off: the box grows
    assert len(far) and np.allclose(far[-1], (62.0, 62.0))


def test_a_leaving_robot_never_heads_straight_at_a_robot_let_in_and_else_stays():
    w, f, jobs = crowd(1)
    jobs.sites.admitted[1] = True
    f.last_z_m[0], jobs.sites.service[0] = SITE + 0.5j, SITE
    f.last_z_m[1] = SITE + 2.0j  # driving in from straight above
    assert jobs.sites.leave(0, 9.0) is True
    end = waypoints(w, 0)[-1]
    assert abs(end - (SITE + (QUEUE_M + EXIT_M) * 1j)) > 1.0  # not straight up at it ...
    assert segment_clearance(f.last_z_m[0], end, f.last_z_m[1:2]) >= w.reach_m_  # ... clear
    # hemmed in: an admitted robot close on every side of the 11 lines -> it stays
    _, f2, jobs2 = crowd(4)
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


# ---- cases a mutation audit found open ---------------------------------------------------


def full_site(extra_at: complex):
    """Robots 1-5 let in to SITE (its five places kept), robot 6 comes for it and is at
    ``extra_at``; robot 7 holds for another site (20 m off) right beside robot 6."""
    starts = [(18.0, 1.0)] + [(2.0 + 1.5 * k, 9.0) for k in range(6)] + [(16.0, 9.0)]
    w = orca_world(starts)
    f, jobs = w.fleet, w.jobs
    give(w, [1, 2, 3, 4, 5, 6, 7], [(10.0, 5.0)] * 6 + [(16.0, 9.0)])
    f.site[1:6] = f.last_z_m[1:6] = jobs.sites.place_points(SITE)  # each on a place of its own
    jobs.sites.admitted[1:6] = True
    f.last_z_m[6] = extra_at
    jobs.sites.holding[7] = True
    f.last_z_m[7] = extra_at + 0.5
    return w, f, jobs


def test_exactly_queue_distance_off_is_not_near_and_a_crowd_of_another_site_is_no_queue():
    w, f, jobs = full_site(SITE + QUEUE_M)  # 12.5 + 5j: exactly QUEUE_M from (10, 5)
    assert abs(f.last_z_m[6] - SITE) == QUEUE_M
    jobs.sites.queue(at(w, 4.0))
    assert not jobs.sites.holding[6] and not jobs.sites.admitted[6]  # beside 7, who holds elsewhere
    f.last_z_m[6] = SITE + QUEUE_M - 1e-9
    jobs.sites.queue(at(w, 5.0))
    assert jobs.sites.holding[6]


def test_a_robot_whose_back_off_ends_now_is_let_in_and_one_still_backing_off_is_not():
    w, f, jobs = crowd(1)
    f.last_z_m[1] = SITE - 1.0
    t = at(w, 6.0)
    f.backoff_until_s[1] = t + 0.1
    jobs.sites.queue(t)
    assert not jobs.sites.admitted[1]
    f.backoff_until_s[1] = t
    jobs.sites.queue(t)
    assert jobs.sites.admitted[1]


def test_leave_needs_the_robot_near_the_site_not_broken_and_someone_coming():
    _, f, jobs = crowd(1)
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


def test_going_round_again_counts_one_more_try():
    w = orca_world([(6.0, 5.0), (8.0, 5.0)])
    f, jobs = w.fleet, w.jobs
    give(w, [0, 1], [(14.0, 5.0), (2.0, 5.0)])
    f.last_z_m[:2] = [7.4 + 5j, 8 + 5j]
    f.recoveries[0] = 1
    assert jobs.jams.go_round(0, 30.0) is True
    assert f.recoveries[0] == 2 and jobs.jams.around_s[0] == 30.0
