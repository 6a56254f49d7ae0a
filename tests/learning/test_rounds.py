"""One announcement round (learning.rounds) on the abstract world, with a spy recorder."""

from __future__ import annotations

import numpy as np

from allocation.costs import make_cost_model
from learning.rounds import drain, play_round
from sim import make_world
from sim.tasks import Batch


class Spy:
    def __init__(self) -> None:
        self.calls = []

    def announce(self, t_s, ids, types, high, sites) -> None:
        row = ("announce", t_s, ids.tolist(), types.tolist(), high.tolist(), np.shape(sites))
        self.calls.append(row)

    def allocate(self, t_s, ids, assignment) -> None:
        self.calls.append(("allocate", t_s, ids.tolist(), assignment.tolist()))

    def done(self, task_id, t_s) -> None:
        self.calls.append(("done", task_id, t_s))


def fixed(assignment):
    def decide(state, batch, costs):
        assert state.free.all() and costs.shape == (3, len(batch))
        return np.array(assignment), costs * 10

    return decide


def batch(ids, types) -> Batch:
    k = len(ids)
    high = np.array([True] + [False] * (k - 1))
    return Batch(0, 0, np.array(ids), np.array(types), high, np.full((k, 2), np.nan))


def test_a_round_prices_applies_advances_and_records(tiny):
    # tiny: R1 {A} cost 1, R2 {A, B} cost 2, 2, R3 {B} cost 1; every task takes 15 s
    world, spy, announced = make_world(tiny), Spy(), batch([10, 11, 12], [0, 1, 1])
    rnd = play_round(
        world,
        announced,
        make_cost_model("abstract", tiny),
        fixed([0, -1, 2]),
        interval_s=20.0,
        recorder=spy,
    )
    np.testing.assert_array_equal(rnd.costs, [[1, np.inf, np.inf], [2, 2, 2], [np.inf, 1, 1]])
    np.testing.assert_array_equal(rnd.bids, rnd.costs * 10)
    assert rnd.won_bid.dtype == float
    np.testing.assert_array_equal(rnd.won_bid, [1.0, np.nan, 1.0])  # the cost, not the bid
    assert rnd.state.time_s == 0.0 and rnd.assignment.tolist() == [0, -1, 2]
    assert rnd.batch is announced
    assert [(c.task_id, c.robot, c.t_done_s, c.bid) for c in rnd.done] == [
        (10, 0, 15.0, 1.0),
        (12, 2, 15.0, 1.0),
    ]
    assert spy.calls == [
        ("announce", 0.0, [10, 11, 12], [0, 1, 1], [True, False, False], (3, 2)),
        ("allocate", 0.0, [10, 11, 12], [0, -1, 2]),
        ("done", 10, 15.0),
        ("done", 12, 15.0),
    ]
    assert world.snapshot().time_s == 20.0


def test_drain_finishes_running_tasks_and_tells_the_recorder(tiny):
    world, spy = make_world(tiny), Spy()
    play_round(
        world,
        batch([7, 8], [0, 1]),
        make_cost_model("abstract", tiny),
        fixed([1, 2]),
        interval_s=5.0,
    )
    done = drain(world, spy)
    assert [(c.task_id, c.t_done_s) for c in done] == [(7, 15.0), (8, 15.0)]
    assert spy.calls == [("done", 7, 15.0), ("done", 8, 15.0)]
    assert drain(world) == []
