"""The experiment loop: conservation, invariants, determinism and the paper's effects."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import stats

from allocation.costs import make_cost_model
from learning import ALLOCATORS
from learning.episode import InvariantError, run_protocol
from scenarios.protocol import RunSpec, execute
from sim.tasks import generate_stream
from sim.world import AbstractWorld


class Spy:
    """Wraps an allocator and keeps what it was shown and what it decided, round by round."""

    def __init__(self, inner):
        self.inner = inner
        self.rounds = []
        self.bids = []

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def allocate(self, state, batch, costs):
        willing = self.inner.willing().copy()
        assignment, bids = self.inner.allocate(state, batch, costs)
        self.rounds.append((batch, state.free.copy(), willing, assignment.copy()))
        self.bids.append(bids.copy())
        return assignment, bids


def play(scenario, name, seed=0):
    ss = np.random.SeedSequence(seed).spawn(3)
    stream = generate_stream(scenario, np.random.default_rng(ss[0]))
    alloc = Spy(ALLOCATORS[name](scenario))
    alloc.reset(np.random.default_rng(ss[2]))
    world = AbstractWorld(scenario)
    rec = run_protocol(
        scenario,
        stream,
        alloc,
        world,
        make_cost_model("abstract", scenario),
        np.random.default_rng(ss[1]),
    )
    return stream, alloc, rec


@pytest.mark.parametrize("name", ["market", "ql", "expt"])
def test_every_task_allocated_or_lost_never_both(small_paper, name):
    stream, _, rec = play(small_paper, name)
    for phase, sets in ((rec.learn, range(4)), (rec.test, range(3, 6))):
        ids, assigned = phase.arrays()
        expected = np.flatnonzero(np.isin(stream.set_index, list(sets)))
        assert sorted(ids.tolist()) == expected.tolist()  # each announced task appears once
        done = sorted(c.task_id for c in phase.completions)
        assert done == sorted(
            ids[assigned >= 0].tolist()
        )  # allocated ones complete, lost ones don't


@pytest.mark.parametrize(
    "name, rule", [("market", "paper"), ("ql", "paper"), ("expt", "paper"), ("expt", "reserve")]
)
def test_no_robot_does_a_task_it_cannot_do_has_refused_or_while_busy(small_paper, name, rule):
    """Paper rule: a refused type is never done. Reserve rule: only when no willing robot was
    left to bid for the task (every willing one was busy, given another task, or waited)."""
    exp = dataclasses.replace(small_paper.experience, refusal=rule)
    _, spy, _ = play(dataclasses.replace(small_paper, experience=exp), name)
    capable = small_paper.capability_matrix()
    refusals_seen = reserve_used = 0
    for (batch, free, willing, assignment), bids in zip(spy.rounds, spy.bids, strict=True):
        refusals_seen += int((capable & ~willing).sum())
        taken = np.flatnonzero(assignment >= 0)
        robots = assignment[taken]
        assert len(set(robots.tolist())) == robots.size
        assert capable[robots, batch.types[taken]].all()
        assert free[robots].all()
        by_reserve = ~willing[robots, batch.types[taken]]
        if rule == "paper":
            assert not by_reserve.any()
        busy_or_given = ~free.copy()
        busy_or_given[robots] = True
        for t in taken[by_reserve]:
            left = willing[:, batch.types[t]] & ~busy_or_given
            assert np.isinf(bids[left, t]).all()  # no willing robot left over bid for it
            reserve_used += 1
    if name == "expt":
        assert refusals_seen > 0  # the checks above really met refused types
    if rule == "reserve":
        assert reserve_used > 0


def test_invariant_violation_stops_the_run(tiny):
    class Cheat:
        learns = False

        def __init__(self, scenario):
            self.capable = scenario.capability_matrix()

        def reset(self, rng): ...
        def begin_set(self, s, learning): ...
        def end_set(self): ...
        def willing(self):
            return self.capable

        def allowed(self):
            return self.capable

        def learning_space(self):
            return np.zeros(3, dtype=np.int64)

        def experience_snapshot(self):
            return None

        def allocate(self, state, batch, costs):
            return np.zeros(len(batch), dtype=int), np.zeros((3, len(batch)))  # R1 takes all

    stream = generate_stream(tiny, np.random.default_rng(0))
    with pytest.raises(InvariantError, match=r"more than one task|cannot do|busy"):
        run_protocol(
            tiny,
            stream,
            Cheat(tiny),
            AbstractWorld(tiny),
            make_cost_model("abstract", tiny),
            np.random.default_rng(0),
        )


def test_same_seed_identical_other_seed_different():
    a = execute(RunSpec("paper", "expt", seed=4))
    b = execute(RunSpec("paper", "expt", seed=4))
    c = execute(RunSpec("paper", "expt", seed=5))
    assert a == b
    assert a["completion"] != c["completion"]


def test_all_allocators_see_the_same_tasks():
    runs = [execute(RunSpec("paper", name, seed=2)) for name in ("market", "ql")]
    assert runs[0]["tasks"]["announced"] == runs[1]["tasks"]["announced"]


@pytest.fixture(scope="module")
def paired_runs():
    seeds = range(6)
    return {
        name: [execute(RunSpec("paper", name, seed=s)) for s in seeds]
        for name in ("market", "ql", "expt")
    }


@pytest.mark.slow
def test_ql_raises_high_priority_completion_and_lowers_low(paired_runs):
    def col(name, prio):
        return np.array([r["completion"]["overall"][prio] for r in paired_runs[name]])

    high_gain = col("ql", "high") - col("market", "high")
    low_gain = col("ql", "low") - col("market", "low")
    assert high_gain.mean() > 0 and stats.ttest_1samp(high_gain, 0.0).pvalue < 0.01
    assert low_gain.mean() < 0 and stats.ttest_1samp(low_gain, 0.0).pvalue < 0.01


@pytest.mark.slow
def test_expt_shrinks_the_space_and_keeps_coverage(paired_runs, paper):
    k = paper.experience.coverage_k
    for run in paired_runs["expt"]:
        space = run["learning_space"]
        assert space["initial"] == 3498
        assert space["final"] < 3498 / 2
        kept = run["experienced_tasks"]
        for t in paper.task_types:
            assert sum(t in types for types in kept.values()) >= k
        for r in paper.robots:  # nobody gains a type it could not do
            assert set(kept[r.name]) <= {paper.task_types[i] for i in r.capabilities}
    for run in paired_runs["ql"]:
        assert run["learning_space"]["final"] == 3498
