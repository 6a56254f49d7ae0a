"""Robot faults (sim.faults): seeded failure and repair times, the worlds' reaction to them."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest

from scenarios.loader import parse_scenario, read_toml, resolve
from sim.faults import FAULT_SPAWN_KEY, FaultModel, build_faults, fault_seed_sequence
from sim.scenario import DriveSpec, FaultSpec, RecoverySpec, RobotSpec, Scenario, SpatialSpec
from sim.spatial.world import PymunkWorld
from sim.states import DRIVING, IDLE
from sim.tasks import Batch
from sim.world import AbstractWorld

# the settings' defaults (sim.scenario), under the names these tests use
REPAIR_WAIT_S = RecoverySpec().repair_wait_s


Z3 = 3.0  # three standard errors: a correct model fails such a check about once in 370 seeds


def model(spec: FaultSpec, m: int, seed: int = 1) -> FaultModel:
    fm = FaultModel(spec, [f"R{j}" for j in range(m)])
    fm.reset(np.random.default_rng(seed))
    return fm


def test_time_to_failure_is_exponential_with_the_mean():
    fm = model(FaultSpec(mttf_s=250.0), 4000)
    ttf = fm.next_fail_s
    se = 250.0 / math.sqrt(ttf.size)  # standard error of the mean of exponentials
    assert abs(ttf.mean() - 250.0) < Z3 * se
    # the median of an exponential is mean * ln 2
    assert abs(np.median(ttf) / (250.0 * math.log(2)) - 1.0) < 0.05


def test_per_robot_means_and_robots_that_never_break():
    spec = FaultSpec(mttf_s=100.0, mttf_by_robot=(("R0", math.inf), ("R1", 1000.0)))
    assert spec.mttf_per_robot(["R0", "R1", "R2"]).tolist() == [math.inf, 1000.0, 100.0]
    draws = np.array([model(spec, 3, seed).next_fail_s for seed in range(2000)])
    assert np.isinf(draws[:, 0]).all()
    for j, mean in ((1, 1000.0), (2, 100.0)):
        assert abs(draws[:, j].mean() - mean) < Z3 * mean / math.sqrt(2000)


def test_fixed_repair_takes_exactly_the_repair_time():
    fm = model(FaultSpec(mttf_s=50.0, repair_s=12.5), 5)
    t0 = float(fm.next_fail_s.min())
    j = int(fm.next_fail_s.argmin())
    broke, fixed = fm.step(t0)
    assert broke == [j] and fixed == []
    assert fm.broken_now()[j] and fm.broken_until_s[j] == t0 + 12.5
    assert fm.next_event_s() <= t0 + 12.5
    fm.step(t0 + 12.5)
    assert not fm.broken_now()[j]
    assert fm.next_fail_s[j] > t0 + 12.5  # a fresh time to failure from the repair
    assert fm.broken_s[j] == pytest.approx(12.5, rel=1e-12)  # (t0 + 12.5) - t0 in floats


def test_exponential_repair_mean():
    fm = model(FaultSpec(mttf_s=10.0, repair_s=30.0, repair="exponential"), 1)
    repairs = []
    while len(repairs) < 3000:
        t = fm.next_event_s()
        broke, _ = fm.step(t)
        if broke:
            repairs.append(fm.broken_until_s[0] - t)
    assert abs(np.mean(repairs) - 30.0) < Z3 * 30.0 / math.sqrt(len(repairs))


def test_permanent_loss():
    fm = model(FaultSpec(mttf_s=10.0, p_permanent=1.0), 3)
    t = float(fm.next_fail_s.max())
    broke, fixed = fm.step(t)
    assert sorted(broke) == [0, 1, 2] and fixed == []
    assert fm.lost.all() and np.isinf(fm.broken_until_s).all()
    assert fm.next_event_s() == math.inf  # nothing is ever due again
    assert fm.broken(1e12).all()
    assert fm.step(math.inf) == ([], []) and fm.lost.all()  # not even by the end of time
    # the share of permanent failures is p_permanent (one failure per robot: repairs take long)
    fm = model(FaultSpec(mttf_s=1.0, repair_s=1e12, p_permanent=0.25), 4000)
    fm.step(1e9)
    assert fm.failures.tolist() == [1] * 4000
    assert abs(fm.lost.mean() - 0.25) < Z3 * math.sqrt(0.25 * 0.75 / 4000)


def test_availability_is_the_share_of_time_not_broken():
    fm = model(FaultSpec(mttf_s=30.0, repair_s=10.0), 400, seed=3)
    fm.step(20_000.0)
    # renewal process: up on average 30 s, then down 10 s
    assert abs(fm.availability(20_000.0).mean() - 0.75) < 0.01
    assert model(FaultSpec(mttf_s=30.0), 2).availability(0.0).tolist() == [1.0, 1.0]


def test_same_seed_same_faults_and_state_round_trip():
    spec = FaultSpec(mttf_s=20.0, repair_s=5.0, repair="exponential", p_permanent=0.1)
    a, b = model(spec, 6, 9), model(spec, 6, 9)
    a.step(100.0)
    b.step(100.0)
    arrays = a.state_arrays()
    assert all(isinstance(v, np.ndarray) and v.dtype != object for v in arrays.values())
    c = model(spec, 6, 0)
    c.restore_arrays(arrays)
    a.step(400.0)
    c.step(400.0)
    b.step(400.0)
    for key in ("next_fail_s", "broken_until_s", "lost", "failures", "broken_s"):
        assert np.array_equal(a.state_arrays()[key], c.state_arrays()[key]), key
        assert np.array_equal(a.state_arrays()[key], b.state_arrays()[key]), key


def test_fault_generator_leaves_the_world_generator_alone():
    rng = np.random.default_rng(np.random.SeedSequence(5).spawn(3)[1])
    twin = np.random.default_rng(np.random.SeedSequence(5).spawn(3)[1])
    seq = fault_seed_sequence(rng)
    assert np.array_equal(rng.random(8), twin.random(8))
    assert seq.spawn_key[:-1] == (1,)
    # deterministic, and not one of the run's three generators
    assert fault_seed_sequence(twin).entropy == seq.entropy
    assert seq.spawn_key not in {(0,), (1,), (2,)}


def test_no_or_empty_faults_table_builds_nothing(paper):
    doc, _ = read_toml(resolve("paper"))
    empty = parse_scenario({**doc, "faults": {}})
    assert not empty.has_faults and build_faults(empty) is None
    assert AbstractWorld(empty).faults is None
    assert not paper.has_faults
    some = parse_scenario({**doc, "faults": {"mttf_s": 100.0, "policy": "drop"}})
    assert some.has_faults and some.faults.policy == "drop"


def test_abstract_world_abandons_the_task_of_a_broken_robot(tiny):
    sc = dataclasses.replace(tiny, faults=FaultSpec(mttf_s=1e9, repair_s=20.0))
    world = AbstractWorld(sc)
    world.reset(np.random.default_rng(0))
    world.faults.next_fail_s[:] = [5.0, np.inf, np.inf]  # R1 breaks at 5 s
    batch = Batch(0, 0, np.array([10, 11]), np.array([0, 1]), np.zeros(2, bool), np.zeros((2, 2)))
    world.apply(batch, np.array([0, 2]), np.array([1.0, 1.0]))
    done = world.advance(10.0)
    assert [c.task_id for c in done] == []  # both take 15 s
    (ab,) = world.take_abandoned()
    assert (ab.task_id, ab.robot, ab.t_alloc_s, ab.t_s) == (10, 0, 0.0, 5.0)
    snap = world.snapshot()
    assert snap.broken.tolist() == [True, False, False]
    assert snap.free.tolist() == [False, True, False]
    assert snap.busy_until_s[0] == 25.0  # repaired at 5 + 20 s
    done = world.advance(10.0)
    assert [(c.task_id, c.robot, c.t_done_s) for c in done] == [(11, 2, 15.0)]
    world.advance(10.0)
    assert world.snapshot().free.tolist() == [True, True, True]
    assert world.take_abandoned() == []


def corridor(**faults) -> Scenario:
    """Two robots on the centre line of an empty 20 m x 6 m hall, R1 ahead of R2."""
    starts = ((8.0, 3.0), (3.0, 3.0))
    sp = SpatialSpec(20.0, 6.0, (), (((16.0, 3.0), (8.0, 3.0)),), DriveSpec())
    robots = tuple(RobotSpec(f"R{j + 1}", (0,), xy) for j, xy in enumerate(starts))
    return Scenario(
        "corridor", ("A",), robots, ((1.0,),) * 2, (2.0,), spatial=sp, faults=FaultSpec(**faults)
    )


@pytest.mark.parametrize("control", ["scalar", "array"])
def test_broken_robot_stops_and_the_other_plans_round_it(control):
    world = PymunkWorld(corridor(mttf_s=1e9, repair_s=1e6), control=control)
    world.reset(np.random.default_rng(0))
    world.faults.next_fail_s[:] = [2.0, np.inf]  # R1 breaks 2 s into its drive
    sites = np.array([[16.0, 3.0], [16.0, 3.0]])
    batch = Batch(0, 0, np.array([0]), np.zeros(1, int), np.zeros(1, bool), sites[:1])
    world.apply(batch, np.array([0]), np.ones(1))
    world.advance(2.0)
    (ab,) = world.take_abandoned()
    assert ab.robot == 0 and ab.task_id == 0
    assert world.fleet.state[0] == IDLE and world.fleet.task[0] == -1
    snap = world.snapshot()
    assert snap.broken.tolist() == [True, False] and not snap.free[0]
    world.advance(3.0)  # it brakes to a stop
    stop_xy = world.poses()[0][0].copy()
    # R2 is sent to the site straight beyond R1: its path goes round the broken robot
    batch = Batch(0, 1, np.array([1]), np.zeros(1, int), np.zeros(1, bool), sites[1:])
    world.apply(batch, np.array([1]), np.ones(1))
    plan = world.path_planner.path(world.poses()[0][1], sites[1])
    assert len(plan) > 2  # not the straight line through R1
    inflate = world.path_planner.inflate_m
    seg = _segment_distance(stop_xy, plan)
    assert seg >= inflate - 1e-6
    done = []
    for _ in range(60):
        done += world.advance(1.0)
        if done:
            break
    assert [(c.task_id, c.ok) for c in done] == [(1, True)], done
    assert np.linalg.norm(world.poses()[0][0] - stop_xy) < 0.05  # R1 stayed where it stopped
    assert world.take_abandoned() == []


def _segment_distance(p: np.ndarray, path: np.ndarray) -> float:
    """Least distance from point p to the polyline ``path``."""
    best = np.inf
    for a, b in itertools.pairwise(path):
        d = b - a
        t = np.clip(np.dot(p - a, d) / max(np.dot(d, d), 1e-12), 0.0, 1.0)
        best = min(best, float(np.linalg.norm(a + t * d - p)))
    return best


def _door_world(repair_s: float, control: str = "scalar") -> PymunkWorld:
    """A 20 m x 6 m hall cut by a wall at x = 12 m with a 1.2 m door (a single lane); R1
    stands in the door and breaks 0.5 s in; then R2, at (3, 3), is sent to (16, 3)."""
    wall = (
        ((11.8, 0.0), (12.2, 0.0), (12.2, 2.4), (11.8, 2.4)),
        ((11.8, 3.6), (12.2, 3.6), (12.2, 6.0), (11.8, 6.0)),
    )
    sp = SpatialSpec(20.0, 6.0, wall, (((16.0, 3.0), (19.0, 3.0)),), DriveSpec())
    robots = (RobotSpec("R1", (0,), (12.0, 3.0)), RobotSpec("R2", (0,), (3.0, 3.0)))
    faults = FaultSpec(mttf_s=1e9, repair_s=repair_s)
    sc = Scenario("door", ("A",), robots, ((1.0,),) * 2, (2.0,), spatial=sp, faults=faults)
    world = PymunkWorld(sc, control=control)
    world.reset(np.random.default_rng(0))
    world.faults.next_fail_s[:] = [0.5, np.inf]
    world.advance(1.0)
    assert world.snapshot().broken.tolist() == [True, False]
    send(world, 1, 7, (16.0, 3.0))
    return world


def send(world: PymunkWorld, robot: int, task: int, site) -> None:
    batch = Batch(0, task, np.array([task]), np.zeros(1, int), np.zeros(1, bool), np.array([site]))
    world.apply(batch, np.array([robot]), np.ones(1))


@pytest.mark.parametrize("control", ["scalar", "array"])
def test_a_way_only_a_broken_robot_blocks_waits_for_the_repair_then_the_task_is_done(control):
    """The broken robot fills the door: the planner that knows where it stands finds no way,
    the scenario's planner does. R2 does not fail as unreachable: it waits where it is (drawn
    as waiting, no stuck clock) until the repair 20 s after the breakdown; then R1 is sent on
    through the door and R2 drives to its site and does the task."""
    from sim.states import WAITING, shown_states

    world = _door_world(20.0, control)
    f, jobs = world.fleet, world.jobs
    assert not len(world.path_planner.path((3.0, 3.0), (16.0, 3.0)))
    assert len(world.planner.path((3.0, 3.0), (16.0, 3.0)))
    assert jobs.blocked.tolist() == [False, True] and f.state[1] == DRIVING
    assert jobs.done == [] and jobs.failures == 0
    start = world.poses()[0][1].copy()
    done = world.advance(19.0)  # t = 20 s: still broken
    assert done == [] and jobs.blocked[1]
    assert shown_states(f.state, f.t_progress_s, world.time_s)[1] == WAITING
    assert np.linalg.norm(world.poses()[0][1] - start) < 0.05  # it held where it was
    done += world.advance(0.6)  # repaired at 20.5 s: R2 has its way again
    assert not jobs.blocked.any() and f.state[1] == DRIVING and done == []
    send(world, 0, 8, (19.0, 3.0))  # R1 leaves the door ahead of R2
    for _ in range(90):
        done += world.advance(1.0)
        if len(done) == 2:
            break
    assert sorted((c.task_id, c.robot, c.ok) for c in done) == [(7, 1, True), (8, 0, True)]
    assert min(c.t_done_s for c in done) > 20.5 + 2.0  # after the repair, and 2 s of work


def test_a_robot_lost_for_good_in_the_way_fails_the_task_with_why_after_the_wait():
    """Lost for good (no repair in sight), the task fails when its deadline, moved on by
    ``REPAIR_WAIT_S``, passes, with the reason: one failure, not a stuck robot."""

    world = _door_world(1e9)
    deadline = float(world.fleet.deadline_s[1])
    assert deadline > world.time_s + REPAIR_WAIT_S
    done = []
    while not done and world.time_s < deadline + 5.0:
        done += world.advance(10.0)
    (c,) = done
    assert (c.task_id, c.ok) == (7, False) and deadline <= c.t_done_s <= deadline + 0.2
    assert c.reason == "unreachable: broken robots in every way to its site until its deadline"
    assert world.jobs.failures == 1 and not world.jobs.blocked.any()


def test_only_broken_robots_make_a_robot_wait():
    """The robot waits only where the planner without broken robots has a way and the one with
    them has none; with no robot broken (or no faults) a task with no way fails as
    unreachable at once, as before (``test_physics``)."""
    world = _door_world(20.0)
    jobs = world.jobs
    assert jobs.blocked_by_broken((3.0, 3.0), (16.0, 3.0))
    jobs.broken[:] = False
    assert not jobs.blocked_by_broken((3.0, 3.0), (16.0, 3.0))


# -- the documented draw order, written out plainly ------------------------------------------
def replay(spec: FaultSpec, m: int, seed: int, n_times: int):
    """The module docstring's draw order as a plain loop: [(t, robots that broke, robots
    repaired)] at the first ``n_times`` event times, and the failures and losses per robot."""
    rng = np.random.default_rng(seed)
    mttf = spec.mttf_per_robot([f"R{j}" for j in range(m)])

    def time_to_failure(j: int, now: float) -> float:
        return now + float(rng.exponential(mttf[j])) if math.isfinite(mttf[j]) else math.inf

    fail = [time_to_failure(j, 0.0) for j in range(m)]
    until, lost, failures, out = [-math.inf] * m, [False] * m, [0] * m, []
    while len(out) < n_times:
        t = min(fail + [u for u in until if math.isfinite(u)])
        if t == math.inf:  # every robot that can break is lost
            break
        broke, fixed = [], []
        while True:  # a zero repair is due at the same time: one step takes both
            due = [j for j in range(m) if until[j] == t]
            for j in due:  # repairs first, by robot index
                until[j], fail[j] = -math.inf, time_to_failure(j, t)
                fixed.append(j)
            failing = [j for j in range(m) if fail[j] == t]
            for j in failing:
                failures[j] += 1
                fail[j] = math.inf
                if spec.p_permanent > 0 and float(rng.random()) < spec.p_permanent:
                    until[j], lost[j] = math.inf, True
                elif spec.repair == "exponential":
                    repair = float(rng.exponential(spec.repair_s)) if spec.repair_s > 0 else 0.0
                    until[j] = t + repair
                else:
                    until[j] = t + spec.repair_s
                broke.append(j)
            if t not in until:
                break
        out.append((t, broke, fixed))
    return out, failures, lost


@pytest.mark.parametrize(
    "spec",
    [
        FaultSpec(
            mttf_s=50.0,
            mttf_by_robot=(("R1", math.inf),),
            repair_s=8.0,
            repair="exponential",
            p_permanent=0.1,
        ),
        FaultSpec(mttf_s=40.0, repair_s=5.0),  # no permanence draw, no repair draw
        FaultSpec(mttf_s=40.0, repair_s=0.0, repair="exponential"),  # a zero mean: no draw
        FaultSpec(mttf_s=40.0, repair_s=0.5, repair="exponential"),
    ],
    ids=["permanent-exponential", "fixed", "zero-exponential", "short-exponential"],
)
def test_failures_and_repairs_follow_the_documented_draw_order(spec):
    expected, failures, lost = replay(spec, 4, seed=7, n_times=40)
    fm = model(spec, 4, seed=7)
    got = []
    while len(got) < 40 and (t := fm.next_event_s()) < math.inf:
        broke, fixed = fm.step(t)
        got.append((t, sorted(broke), sorted(fixed)))
    assert got == [(t, sorted(b), sorted(f)) for t, b, f in expected]
    assert fm.failures.dtype == np.int64 and fm.failures.tolist() == failures
    assert fm.lost.dtype == bool and fm.lost.tolist() == lost
    assert sum(failures) >= 10 and (spec.p_permanent == 0) == (not any(lost))
    assert fm.lost.tolist() == lost and np.isinf(fm.broken_until_s[lost]).all()


def test_exponential_repairs_vary_as_an_exponential_does():
    """Fixed repairs have the same mean: the spread tells the two apart."""
    fm = model(FaultSpec(mttf_s=10.0, repair_s=30.0, repair="exponential"), 1)
    repairs = []
    while len(repairs) < 3000:
        t = fm.next_event_s()
        if fm.step(t)[0]:
            repairs.append(fm.broken_until_s[0] - t)
    # an exponential's standard deviation is its mean; its median is mean * ln 2
    assert abs(np.std(repairs) / 30.0 - 1.0) < 0.1
    assert abs(np.median(repairs) / (30.0 * math.log(2)) - 1.0) < 0.1


def test_availability_while_broken_counts_the_time_down_so_far():
    fm = model(FaultSpec(mttf_s=1e12, repair_s=10.0), 3)
    fm.next_fail_s[:] = [0.25, math.inf, math.inf]
    fm.step(0.25)
    assert fm.availability(0.5).tolist() == [0.5, 1.0, 1.0]  # down 0.25 s of 0.5 s
    assert fm.availability(4.25).tolist() == [1.0 - 4.0 / 4.25, 1.0, 1.0]
    fm.step(10.25)  # repaired: the 10 s are kept
    assert fm.availability(20.0).tolist() == [0.5, 1.0, 1.0]


def test_a_robot_is_broken_until_the_moment_of_its_repair():
    fm = model(FaultSpec(mttf_s=1e12, repair_s=10.0), 2)
    fm.next_fail_s[:] = [3.0, math.inf]
    assert fm.broken(3.0).tolist() == [False, False]  # before the step that applies it
    fm.step(3.0)
    assert fm.broken(12.999).tolist() == [True, False]
    assert fm.broken(13.0).tolist() == [False, False]
    assert fm.broken_now().tolist() == [True, False]
    assert fm.step(13.0) == ([], [0])
    assert fm.broken(20.0).tolist() == [False, False] and not fm.broken_now().any()
    assert fm.broken_until_s.tolist() == [-math.inf, -math.inf]


def test_a_state_for_another_fleet_is_refused_before_anything_changes():
    three = model(FaultSpec(mttf_s=20.0), 3, seed=4)
    two = model(FaultSpec(mttf_s=20.0), 2, seed=5)
    before = {k: v.copy() for k, v in two.state_arrays().items()}
    with pytest.raises(ValueError, match=r"^fault state for 3 robots, not 2$"):
        two.restore_arrays(three.state_arrays())
    after = two.state_arrays()
    assert all(np.array_equal(before[k], after[k]) for k in before if k != "broke_at_s")
    assert np.array_equal(before["broke_at_s"], after["broke_at_s"], equal_nan=True)


def test_a_generator_without_a_seed_sequence_gets_seed_0s_fault_sequence():
    class Bare:  # a bit generator that does not keep the sequence it was seeded from
        pass

    class Gen:
        bit_generator = Bare()

    seq = fault_seed_sequence(Gen())
    assert seq.entropy == 0 and seq.spawn_key == (FAULT_SPAWN_KEY,)


def test_a_new_model_draws_as_one_reset_from_seed_sequence_0():
    spec = FaultSpec(mttf_s=100.0)
    fresh = FaultModel(spec, ["A", "B", "C"])
    reset = model(spec, 3, seed=0)
    assert fresh.next_fail_s.tolist() == reset.next_fail_s.tolist()
    assert fresh.next_fail_s.tolist() != model(spec, 3, seed=1).next_fail_s.tolist()
