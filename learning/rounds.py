"""One announcement round, the one door every loop goes through.

A round takes the world's snapshot, prices the announced batch with the cost model, lets a
``decide`` callback turn (state, batch, costs) into an assignment and the bids behind it, starts
the won tasks in the world, lets the announcement interval pass and tells the recorder. The
experiment loop (:func:`learning.episode.run_protocol`, where ``decide`` is the allocator plus
the invariant checks) and both environments (:mod:`learning.gym_env`, :mod:`learning.pz_env`,
where ``decide`` resolves the agents' bid/wait actions) all play their rounds with
:func:`play_round` and empty the world between sets with :func:`drain`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from allocation.costs import CostModel
from sim.tasks import Batch
from sim.world import Abandon, Completion, World, WorldState

Decide = Callable[[WorldState, Batch, np.ndarray], tuple[np.ndarray, np.ndarray]]
"""``decide(state, batch, costs) -> (assignment, bids)``: ``assignment[t]`` is the robot given
task t (-1 = lost); ``bids`` is (m, k), whatever the caller's decision rests on."""


@dataclass(frozen=True, slots=True)
class Round:
    """What one round saw and did."""

    state: WorldState  # snapshot at the announcement
    batch: Batch
    costs: np.ndarray  # (m, k) cost model's prices
    assignment: np.ndarray  # (k,) robot per task, -1 = lost
    bids: np.ndarray  # (m, k) from ``decide``
    won_bid: np.ndarray  # (k,) cost of the winner per task, NaN if lost
    done: list[Completion]  # tasks that ended during the interval
    abandoned: list[Abandon] = field(default_factory=list)  # given up: their robot broke


def play_round(
    world: World,
    batch: Batch,
    cost_model: CostModel,
    decide: Decide,
    interval_s: float,
    recorder=None,
) -> Round:
    """Play one announcement round: snapshot, costs, decide, apply, advance, record.

    Args:
        world: the world the tasks are done in.
        batch: the tasks announced in this round.
        cost_model: prices every (robot, task) pair from the snapshot.
        decide: turns (state, batch, costs) into (assignment, bids).
        interval_s: seconds until the next announcement.
        recorder: a ``sim.recording.TrajectoryRecorder`` told of the announcement, the
            allocation and the tasks that ended, or None.
    """
    state = world.snapshot()
    costs = cost_model.costs(state, batch)
    assignment, bids = decide(state, batch, costs)
    won = assignment >= 0
    won_bid = np.full(len(batch), np.nan)
    won_bid[won] = costs[assignment[won], np.flatnonzero(won)]
    world.apply(batch, assignment, won_bid)
    done = world.advance(interval_s)
    abandoned = world.take_abandoned()
    if recorder is not None:
        recorder.announce(state.time_s, batch.ids, batch.types, batch.high, batch.sites)
        recorder.allocate(state.time_s, batch.ids, assignment)
        for c in done:
            recorder.done(c.task_id, c.t_done_s)
    return Round(state, batch, costs, assignment, bids, won_bid, done, abandoned)


def drain(world: World, recorder=None) -> list[Completion]:
    """Finish every running task (the end of a set) and tell the recorder. Tasks abandoned
    on the way (a robot broke) are left in the world for ``World.take_abandoned``."""
    done = world.drain()
    if recorder is not None:
        for c in done:
            recorder.done(c.task_id, c.t_done_s)
    return done
