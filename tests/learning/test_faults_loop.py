"""Robot faults in the experiment loop: fates, requeue/drop, invariants, experience, resume."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.special import expit

import learning.checkpoint as ck
from allocation.costs import make_cost_model
from learning import ALLOCATORS
from learning.episode import InvariantError, run_protocol
from learning.experience import B2_REFUSED
from learning.exptmrta import ExpTAllocator
from learning.fates import FATES, FateError, FateLedger
from learning.qlmrta import QLAllocator
from scenarios.protocol import RunSpec, execute
from sim.scenario import FaultSpec
from sim.tasks import Batch, generate_stream
from sim.world import Abandon, AbstractWorld, Completion, WorldState


class Spy:
    """Wraps an allocator; keeps every batch and state it was shown and what it decided."""

    def __init__(self, inner):
        self.inner = inner
        self.rounds = []

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def allocate(self, state, batch, costs):
        assignment, bids = self.inner.allocate(state, batch, costs)
        self.rounds.append((batch, state, assignment.copy()))
        return assignment, bids


def faulty(scenario, **faults):
    return dataclasses.replace(scenario, faults=FaultSpec(**faults))


def play(scenario, name, seed=0, allocator=None):
    ss = np.random.SeedSequence(seed).spawn(3)
    stream = generate_stream(scenario, np.random.default_rng(ss[0]))
    alloc = Spy(allocator or ALLOCATORS[name](scenario))
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
    return stream, alloc, rec, world


@pytest.mark.parametrize("name", ["market", "ql", "expt", "greedy", "cbba"])
@pytest.mark.parametrize("policy", ["requeue", "drop"])
def test_every_task_ends_exactly_once(small_paper, name, policy):
    sc = faulty(small_paper, mttf_s=150.0, repair_s=40.0, policy=policy)
    stream, _, rec, _ = play(sc, name)
    for phase, sets in ((rec.learn, range(4)), (rec.test, range(3, 6))):
        expected = np.flatnonzero(np.isin(stream.set_index, list(sets)))
        # the learning and test phases overlap in set 3: a task id appears once per set played
        rows = phase.fate_rows
        assert sorted(r[0] for r in rows) == sorted(expected.tolist())
        assert int(phase.fates.sum()) == expected.size
        fate = {r[0]: r[1] for r in rows}
        done = [c.task_id for c in phase.completions if c.ok]
        assert len(done) == len(set(done))  # done at most once
        assert {fate[t] for t in done} <= {"done", "abandoned_done"}
        aband = {a.task_id for a in phase.abandons}
        assert all(fate[t].startswith("abandoned") for t in aband)
        assert all(not fate[t].startswith("abandoned") for t in set(fate) - aband)
    total = rec.learn.abandon_ends.sum() + rec.test.abandon_ends.sum()
    assert total > 0  # the faults did something
    if policy == "drop":
        assert rec.learn.abandon_ends[0] == rec.test.abandon_ends[0] == 0  # nothing re-announced


def test_requeued_task_keeps_id_type_priority_site_and_age(small_paper):
    sc = faulty(small_paper, mttf_s=100.0, repair_s=30.0)
    stream, spy, rec, _ = play(sc, "market")
    seen: dict[tuple[int, int], list] = {}  # (set played, task): set 3 is played twice
    play_no = -1
    for batch, state, assignment in spy.rounds:
        play_no += batch.round_index == 0
        for k, tid in enumerate(batch.ids.tolist()):
            seen.setdefault((play_no, tid), []).append(
                (int(batch.types[k]), bool(batch.high[k]), state.time_s, int(assignment[k]))
            )
    again = {t: v for t, v in seen.items() if len(v) > 1}
    assert again, "no task was re-announced"
    first = [{r[0]: r[3] for r in phase.fate_rows} for phase in (rec.learn, rec.test)]
    for (play_no, tid), rows in again.items():
        assert {(r[0], r[1]) for r in rows} == {(int(stream.types[tid]), bool(stream.high[tid]))}
        assert all(r[3] >= 0 for r in rows[:-1])  # re-announced only after being allocated
        assert first[play_no >= 4][tid] == rows[0][2]  # age from the first announcement
        assert [r[2] for r in rows] == sorted(r[2] for r in rows)


def test_broken_robot_is_never_free_nor_given_a_task(small_paper):
    sc = faulty(small_paper, mttf_s=80.0, repair_s=60.0)
    _, spy, _, _ = play(sc, "market")
    broken_rounds = 0
    for _, state, assignment in spy.rounds:
        assert not (state.free & state.broken).any()
        assert not state.broken[assignment[assignment >= 0]].any()
        broken_rounds += bool(state.broken.any())
    assert broken_rounds > 0


class GivesToBroken:
    """A faulty allocator: every task to robot 0, broken or not, free or not."""

    name, learns = "bad", False

    def __init__(self, scenario):
        self.scenario = scenario
        self.capable = scenario.capability_matrix()

    def reset(self, rng):
        pass

    def begin_set(self, s, learning):
        pass

    def end_set(self):
        pass

    def allocate(self, state, batch, costs):
        out = np.full(len(batch), -1)
        if state.broken is not None and state.broken[0]:
            t = np.flatnonzero(self.capable[0, batch.types])
            if t.size:
                out[t[0]] = 0
        return out, np.where(True, costs, np.inf)

    def willing(self):
        return self.capable

    def allowed(self):
        return self.capable

    def learning_space(self):
        return np.zeros(self.scenario.n_robots, dtype=np.int64)

    def experience_snapshot(self):
        return None


def test_invariant_rejects_a_task_for_a_broken_robot(small_paper):
    sc = faulty(small_paper, mttf_s=60.0, repair_s=200.0)
    with pytest.raises(InvariantError, match="broken robot 0 was given a task"):
        play(sc, "", allocator=GivesToBroken(sc))


def batch(ids, types=None, high=None):
    ids = np.asarray(ids)
    k = ids.size
    types = np.zeros(k, int) if types is None else np.asarray(types)
    high = np.zeros(k, bool) if high is None else np.asarray(high)
    return Batch(0, 0, ids, types, high, np.arange(2 * k, dtype=float).reshape(k, 2))


def test_ledger_fires_on_a_double_count_and_on_a_vanished_task():
    led = FateLedger("requeue", "test set 0")
    led.announce(batch([1, 2]), 0.0)
    led.allocate(np.array([1, 2]), np.array([0, 1]))
    led.complete(Completion(1, 0, 0.0, 5.0, 1.0))
    with pytest.raises(FateError, match="task 1 completed while ended"):
        led.complete(Completion(1, 0, 0.0, 6.0, 1.0))
    with pytest.raises(FateError, match="task 2 has no fate at the end of the set"):
        led.close()  # task 2 was allocated and never came back: vanished
    led = FateLedger("requeue", "s")
    led.announce(batch([3]), 0.0)
    with pytest.raises(FateError, match="task 3 announced again while announced"):
        led.announce(batch([3]), 10.0)
    led = FateLedger("requeue", "s")
    led.announce(batch([4]), 0.0)
    led.allocate(np.array([4]), np.array([2]))
    led.abandon(Abandon(4, 2, 0.0, 3.0, 1.0))
    with pytest.raises(FateError, match="task 4 was abandoned and not re-announced"):
        led.announce(batch([5]), 10.0)  # the caller forgot with_requeued


def test_ledger_requeue_and_drop():
    led = FateLedger("requeue", "s")
    led.announce(batch([7], types=[3], high=[True]), 0.0)
    led.allocate(np.array([7]), np.array([1]))
    led.abandon(Abandon(7, 1, 0.0, 4.0, 1.0))
    nxt = led.with_requeued(batch([8]))
    assert nxt.ids.tolist() == [8, 7] and nxt.types.tolist() == [0, 3]
    assert nxt.high.tolist() == [False, True] and nxt.sites[1].tolist() == [0.0, 1.0]
    led.announce(nxt, 10.0)
    led.allocate(nxt.ids, np.array([-1, 2]))
    led.complete(Completion(7, 2, 10.0, 20.0, 1.0))
    counts = led.close()
    assert counts == {**dict.fromkeys(FATES, 0), "lost": 1, "abandoned_done": 1}
    assert led.tasks[7].announced_s == 0.0 and led.tasks[7].announcements == 2
    assert led.ends == {"requeued": 1, "dropped": 0, "set_end": 0}

    led = FateLedger("drop", "s")
    led.announce(batch([9]), 0.0)
    led.allocate(np.array([9]), np.array([0]))
    led.abandon(Abandon(9, 0, 0.0, 4.0, 1.0))
    assert led.with_requeued(batch([10])).ids.tolist() == [10]
    counts = led.close()
    assert counts["abandoned_lost"] == 1 and led.ends["dropped"] == 1


def test_abandoned_at_the_end_of_a_set_is_lost_then():
    led = FateLedger("requeue", "s")
    led.announce(batch([1]), 0.0)
    led.allocate(np.array([1]), np.array([0]))
    led.abandon(Abandon(1, 0, 0.0, 4.0, 1.0))
    assert led.close()["abandoned_lost"] == 1
    assert led.ends["set_end"] == 1


def test_expt_withholds_the_experience_of_an_abandoned_win(tiny):
    """Hand-computed: R1 and R2 bid for one A task (b = 2), R1 wins.

    Credited: eta = 1, mu = 1/2, v = 2 expit(1/2) = 1.2449; after the abandonment R1's record is
    that of a bidder that did not win: eta = 0, mu = 1/2, v = u = 2 expit(-1/2) = 0.7551.
    R2's record (a bidder that lost) is untouched: v = 2 expit(-1/2)."""
    alloc = ExpTAllocator(tiny)
    alloc.reset(np.random.default_rng(0))
    alloc.begin_set(0, learning=True)
    state = WorldState(0.0, np.ones(3, bool), np.zeros(3))
    b = Batch(0, 0, np.array([0]), np.array([0]), np.array([True]), np.zeros((1, 2)))
    costs = np.array([[1.0], [2.0], [np.inf]])
    assignment, _ = alloc.allocate(state, b, costs)
    assert assignment.tolist() == [0]
    exp = alloc.experience_
    assert exp.eta_[0, 0] == 1.0 and exp.mu_[0, 0] == 0.5
    assert exp.v_[0, 0] == pytest.approx(1.2449186624037092, abs=1e-15)
    assert 2 * expit(0.5) == pytest.approx(1.2449186624037092, abs=1e-15)
    alloc.task_abandoned(0, 0)
    assert exp.eta_[0, 0] == 0.0 and exp.mu_[0, 0] == 0.5
    assert exp.v_[0, 0] == pytest.approx(0.7550813375962908, abs=1e-15)
    assert exp.u_[0, 0] == pytest.approx(0.7550813375962908, abs=1e-15)
    assert exp.count_[0, 0] == 1
    assert exp.v_[1, 0] == pytest.approx(0.7550813375962908, abs=1e-15)
    # a second abandonment (nothing credited any more) changes nothing
    alloc.task_abandoned(0, 0)
    assert exp.eta_[0, 0] == 0.0 and exp.v_sum_[0, 0] == pytest.approx(0.7550813375962908)


def test_expt_on_the_test_sets_has_nothing_to_withhold(tiny):
    alloc = ExpTAllocator(tiny)
    alloc.reset(np.random.default_rng(0))
    alloc.begin_set(0, learning=False)
    state = WorldState(0.0, np.ones(3, bool), np.zeros(3))
    b = Batch(0, 0, np.array([0]), np.array([0]), np.array([True]), np.zeros((1, 2)))
    alloc.allocate(state, b, np.array([[1.0], [2.0], [np.inf]]))
    before = alloc.experience_.robot_state(0, 0)
    alloc.task_abandoned(0, 0)
    assert alloc.experience_.robot_state(0, 0) == before


def test_without_faults_nothing_is_abandoned(small_paper):
    _, _, rec, world = play(small_paper, "expt")
    assert world.faults is None
    assert rec.test.abandons == [] and rec.test.abandon_ends.sum() == 0
    assert rec.test.fates[FATES.index("abandoned_lost")] == 0
    assert rec.availability is None


FAULT_TOML = """
[faults]
mttf_s = 200.0
repair_s = 45.0
repair = "exponential"
p_permanent = 0.05
"""


def test_abstract_resume_with_faults_equals_straight_run(tmp_path, monkeypatch):
    from scenarios.loader import resolve

    path = tmp_path / "paper_faults.toml"
    path.write_text(resolve("paper").read_text() + FAULT_TOML)
    spec = RunSpec(str(path), "expt", seed=3)
    straight = execute(spec, checkpoint=tmp_path / "a.npz")
    assert straight["faults"]["abandoned"] > 0

    class Stop(Exception):
        pass

    real = ck.save_checkpoint
    calls = {"n": 0}

    def save_then_stop(p, arrays, meta):
        real(p, arrays, meta)
        calls["n"] += 1
        if calls["n"] == 20:
            raise Stop

    monkeypatch.setattr("scenarios.experiments.protocol.save_checkpoint", save_then_stop)
    with pytest.raises(Stop):
        execute(spec, checkpoint=tmp_path / "b.npz")
    monkeypatch.setattr("scenarios.experiments.protocol.save_checkpoint", real)
    arrays, _ = ck.load_checkpoint(tmp_path / "b.npz")
    assert "world/faults/next_fail_s" in arrays
    resumed = execute(spec, checkpoint=tmp_path / "b.npz", resume=True)
    assert resumed == straight


@pytest.mark.parametrize("cls", [QLAllocator, ExpTAllocator])
def test_an_abandoned_task_frees_only_its_robot_of_a_low_task(tiny, cls):
    alloc = cls(tiny)
    alloc.reset(np.random.default_rng(0))
    alloc.busy_low_[:] = True
    alloc.task_abandoned(1, 0)
    assert alloc.busy_low_.tolist() == [True, False, True]


def test_expt_keeps_a_refusal_made_after_the_abandoned_win(tiny):
    alloc = ExpTAllocator(tiny)
    alloc.reset(np.random.default_rng(0))
    alloc.begin_set(0, learning=True)
    state = WorldState(0.0, np.ones(3, bool), np.zeros(3))
    b = Batch(0, 0, np.array([0]), np.array([0]), np.array([True]), np.zeros((1, 2)))
    alloc.allocate(state, b, np.array([[1.0], [2.0], [np.inf]]))
    alloc.experience_.behaviour_[0, 0] = B2_REFUSED  # refused meanwhile
    alloc.task_abandoned(0, 0)
    assert alloc.experience_.behaviour_[0, 0] == B2_REFUSED
    assert alloc.experience_.eta_[0, 0] == 0.0  # the win is withheld all the same


def test_expt_forgets_the_credit_of_a_finished_task(tiny):
    """A robot seen free again has finished its task: its credit is dropped (so a later
    abandonment cannot withhold it); a robot still at work keeps its credit."""
    alloc = ExpTAllocator(tiny)
    alloc.reset(np.random.default_rng(0))
    alloc.begin_set(0, learning=True)
    b = Batch(0, 0, np.array([0]), np.array([0]), np.array([True]), np.zeros((1, 2)))
    alloc.allocate(
        WorldState(0.0, np.ones(3, bool), np.zeros(3)), b, np.array([[1.0], [2.0], [np.inf]])
    )
    assert set(alloc.credit_) == {0}
    nobody = np.full((3, 1), np.inf)  # no robot can take the next task
    alloc.allocate(WorldState(10.0, np.array([False, True, True]), np.zeros(3)), b, nobody)
    assert set(alloc.credit_) == {0}  # robot 0 still at work
    alloc.allocate(WorldState(20.0, np.array([True, False, False]), np.zeros(3)), b, nobody)
    assert alloc.credit_ == {}  # robot 0 free again: done, nothing to withhold
