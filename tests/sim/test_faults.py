"""Robot faults (sim.faults): seeded failure and repair times, the worlds' reaction to them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios.loader import parse_scenario, read_toml, resolve
from sim.faults import FAULT_SPAWN_KEY, FaultModel, build_faults, fault_seed_sequence
from sim.scenario import FaultSpec
from sim.world import AbstractWorld

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


@pytest.mark.slow
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
