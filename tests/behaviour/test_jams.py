"""Jams in whole runs of the pymunk world: a robot beside one at work in a gap goes round it
``pass_s`` after it stops (``[spatial.jams]``), without a recovery try, or plans round it as soon
as it begins work (``look_ahead``). The rules one by one are in
``tests/sim/spatial/test_jams.py``."""

from __future__ import annotations

import numpy as np
import pytest

from sim.scenario import JamSpec
from sim.scenario.spatial import TrafficSpec
from sim.states import DRIVING, WORKING
from tests.worlds import swap_world, time_to_all_arrive, waypoints

PASS_S = JamSpec().pass_s


def _gap_world(second_gap_y: float, look_ahead: str = "off", pass_s: float = JamSpec().pass_s):
    """A wall across a 12 x 8 m arena at x = 6 with a 1.4 m gap at y = 3, where a robot works
    (1000 s), and a second gap centred at ``second_gap_y``; robot 0 drives from (3, 3) to
    (9, 3), straight through the first gap (the planner ignores robots; ``[spatial]
    look_ahead`` as given). The traffic rules are off: these are the jam rules they fall back
    on."""
    lo, hi = second_gap_y - 0.7, second_gap_y + 0.7
    walls = [((5.9, a), (6.1, a), (6.1, b), (5.9, b)) for a, b in [(0, 2.3), (3.7, lo), (hi, 8)]]
    starts, goals = [(3.0, 3.0), (6.0, 3.0)], [(9.0, 3.0), (6.0, 3.0)]
    jams = JamSpec(pass_s=pass_s)
    return swap_world(
        starts,
        goals,
        (12.0, 8.0),
        "auto",
        "orca",
        walls,
        look_ahead=look_ahead,
        settings={"jams": jams, "traffic": TrafficSpec(rules="off")},
    )


def _arrive(world) -> tuple[float, float]:
    """When robot 0 starts work at its site (inf: not within 60 s), and the highest it went."""
    top = [0.0]

    def watch(w):
        top[0] = max(top[0], float(w.fleet.last_z_m[0].imag))

    t = time_to_all_arrive(world, 60.0, lambda w: w.fleet.state[0] == WORKING, watch)
    return t, top[0]


def test_a_robot_beside_one_at_work_at_another_site_goes_round_it_without_a_try():
    """The worker fills the gap (0.45 m either side, a robot needs 0.7): robot 0 stands
    beside it, and ``pass_s`` later (not the stuck timeout) takes the way through the other
    gap, 2.3 m longer, without spending a recovery try; with the rule off it waits for the
    stuck timeout and then goes round, spending one. Where the only way round is more than
    ``pass_extra_m`` longer the rule leaves every robot exactly as it was."""
    runs = {}
    for rule in (True, False):
        for gap_y in (5.0, 6.9):
            world = _gap_world(gap_y, pass_s=PASS_S if rule else 3600.0)
            runs[rule, gap_y] = world, *_arrive(world)
    (on, t_on, top_on), (off, t_off, top_off) = runs[True, 5.0], runs[False, 5.0]
    assert top_on > 4.3 and top_off > 4.3  # both through the second gap in the end
    assert on.fleet.recoveries[0] == 0 and off.fleet.recoveries[0] == 1
    stuck_s = on.spatial.stuck_timeout_s
    assert t_off - t_on > stuck_s - PASS_S - 2.0  # the wait it saves, less the turns
    (far, t_far, _), (far_off, t_far_off, _) = runs[True, 6.9], runs[False, 6.9]
    assert np.isfinite(t_far) and t_far == t_far_off
    assert np.array_equal(far.fleet.last_z_m, far_off.fleet.last_z_m)
    assert far.fleet.recoveries.tolist() == far_off.fleet.recoveries.tolist() == [1, 0]


def test_going_round_skips_a_robot_at_work_for_the_same_site():
    """The rule leaves a robot alone whose neighbour at work works for the robot's own site
    (the site's queue and slots decide who goes where), and re-plans it, through the second
    gap, when that robot works for another site: the same moment, called directly."""
    world = _gap_world(5.0, pass_s=3600.0)  # the rule off while the robot comes up
    while world.time_s < 10.0:
        world.advance(0.1)
    f, jobs, t = world.fleet, world.jobs, world.time_s
    assert f.state[0] == DRIVING and f.state[1] == WORKING
    assert abs(f.v_cmd_mps[0]) < 0.1 and t - f.t_progress_s[0] >= 2.0
    jobs.jams.rules = JamSpec(pass_s=2.0)  # the rule on from now
    before, clock = waypoints(world, 0).copy(), f.t_progress_s[0]
    own = jobs.sites.service[0]
    jobs.sites.service[0] = jobs.sites.service[1]  # as if both worked for one site
    jobs.jams.pass_workers(t)
    assert np.array_equal(waypoints(world, 0), before) and f.t_progress_s[0] == clock
    jobs.sites.service[0] = own
    jobs.jams.pass_workers(t)
    after = waypoints(world, 0)
    assert f.t_progress_s[0] == t and after.imag.max() > 4.3  # through the second gap
    assert f.recoveries[0] == 0


def _first_look(world):
    """Advance ``world`` (``_gap_world``) until robot 1 is at work and robot 0 has been looked
    at (the period after robot 1 began work); the time."""
    jams = world.jobs.jams
    while not (world.fleet.state[1] == WORKING and not (jams.due.any() or jams.began.any())):
        world.advance(0.1)
        assert world.time_s < 5.0
    return world.time_s


def test_a_robot_plans_round_one_at_work_in_its_way_before_it_gets_there():
    """Robot 1 works (1000 s) in the gap robot 0's way runs through: as soon as robot 1 is
    at work robot 0 plans its way through the second gap (2.3 m longer, far quicker than
    waiting), without a try and before it has come near; it reaches its site sooner than
    with ``[spatial] look_ahead = "off"`` (the default: it drives up, stands ``PASS_S``
    beside the robot at work and goes round, ``pass_workers``), whose way is still the
    straight one then."""

    off = _gap_world(5.0)
    while off.fleet.state[1] != WORKING:
        off.advance(0.1)
    off.advance(0.2)
    assert waypoints(off, 0).imag.max() < 3.1  # the way it was given: through robot 1
    world = _gap_world(5.0, look_ahead="on")
    t0 = _first_look(world)
    f = world.fleet
    assert t0 < 1.0 and waypoints(world, 0).imag.max() > 4.3  # through the second gap
    assert abs(f.last_z_m[0] - (3 + 3j)) < 0.3 and f.recoveries[0] == 0
    t_on, top_on = _arrive(world)
    t_off, top_off = _arrive(off)
    assert top_on > 4.3 and top_off > 4.3
    assert np.isfinite(t_on) and t_on < t_off - PASS_S


def test_looking_ahead_keeps_the_way_when_waiting_is_quicker_or_the_site_is_shared():
    """Robot 0's way passes robot 1 at work about 3 m ahead; the other gap is far (the way
    round it several metres longer). Robot 0 keeps its way, unchanged and its clock
    untouched, when robot 1's work ends before robot 0 would wait ``AHEAD_WAIT_S`` there,
    when the way round takes 0.1 s longer at top speed than the wait, and when robot 1 works
    for robot 0's own site (the site's queue and slots decide); with the wait 0.1 s longer
    than the way round it goes round. Called directly, at one moment."""

    wait_s = JamSpec().ahead_wait_s
    world = _gap_world(6.9)  # look_ahead "off": only the direct calls below look
    f, jobs = world.fleet, world.jobs
    while f.state[1] != WORKING:
        world.advance(0.1)
    t = world.time_s
    before, clock = waypoints(world, 0).copy(), f.t_progress_s[0]
    wait, along, gap = jobs.jams.waits(np.array([0]), np.array([1]), t)
    assert gap[0, 0] < 0.1  # the way runs through robot 1's gap
    assert 2.5 < along[0, 0] < 3.2  # the way to the point passing robot 1
    arrive = t + along[0, 0] / world.follower.v_max_mps
    assert wait[0, 0] == pytest.approx(f.work_end_s[1] - arrive)
    z0 = f.last_z_m[0]
    for x, waits in ((5.0, True), (5.3, False)):  # the point nearest robot 1: 1.0 / 0.7 m on
        f.last_z_m[0] = complex(x, 3.0)
        assert (jobs.jams.waits(np.array([0]), np.array([1]), t)[0][0, 0] > 0) == waits
    f.last_z_m[0] = z0  # beside it already (within AHEAD_BLOCK_M along its way): pass_workers
    grown = world.controller.radius_m + JamSpec().ahead_grow_m
    z = f.last_z_m
    way = world.planner.path_around((z[0].real, z[0].imag), (9.0, 3.0), z[[1]], grown)
    extra_s = float(np.abs(np.diff(way[:, 0] + 1j * way[:, 1])).sum()) - jobs.jams.way_left_m(0)
    extra_s /= world.follower.v_max_mps
    assert wait_s + 1.0 < extra_s < 10.0

    def look(work_left_s: float, service=None) -> bool:
        f.work_end_s[1] = arrive + work_left_s
        own = jobs.sites.service[0]
        if service is not None:
            jobs.sites.service[0] = service
        jobs.jams.due[0] = True
        jobs.jams.look_ahead(t)
        jobs.sites.service[0] = own
        assert not (jobs.jams.due.any() or jobs.jams.began.any())
        return not np.array_equal(waypoints(world, 0), before)

    assert not look(wait_s - 0.1)  # it ends before the robot would wait long
    assert not look(extra_s - 0.1)  # waiting is quicker than the way round
    assert not look(1000.0, service=jobs.sites.service[1])  # the same site
    assert f.t_progress_s[0] == clock and f.recoveries[0] == 0
    assert look(extra_s + 0.1)  # the way round is quicker: round it
    assert waypoints(world, 0).imag.max() > 6.0 and f.t_progress_s[0] == t
