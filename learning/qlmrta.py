"""QL-MRTA (SPEC §3): each robot learns to bid for a low-priority task or to wait.

Every robot keeps its own :class:`HistoryQTable`. When a low-priority task it can do is
announced and it is free, it chooses ``do`` (bid) or ``wait``; high-priority tasks are always
bid for. The auction is the market's exact priority assignment over the bids placed.

Reward (ours; the paper leaves it open). A decision's reward is everything that happens to the
robot until its next decision:

- ``do`` and the robot wins the task: ``+reward_low``, then ``-penalty_lost_high`` for every
  high-priority task of a type it can do that is lost while it is busy with that low task;
- a high-priority task won: ``+reward_high`` (credited to the decision that kept it free);
- anything else: 0.

With the defaults (5, 1, 5) a high task is worth five low ones, and a low task taken while a
high task the robot could have done is lost is a net loss (1 - 5 < 0).
"""

from __future__ import annotations

import numpy as np

from allocation.auction import solve_priority_assignment
from learning.learner import Decision, QLearners
from learning.qtable import DO, WAIT, space_size
from sim.scenario import Scenario
from sim.tasks import Batch
from sim.world import WorldState


class QLAllocator:
    """QL-MRTA: independent tabular Q-learners deciding do/wait on low-priority tasks.

    The learners (tables, open decisions, epsilon schedule, exploration generator) are one
    :class:`learning.learner.QLearners`, ``learner_``; the allocator turns their decisions into
    bids, runs the auction and credits the rewards.
    """

    name = "ql"
    learns = True

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.capable = scenario.capability_matrix()
        self.learn = scenario.learning
        self.reset(np.random.default_rng(0))

    # -- lifecycle ---------------------------------------------------------------------------
    def reset(self, rng: np.random.Generator) -> None:
        """Forget everything; ``rng`` drives exploration."""
        self.learner_ = QLearners(self.capable, self.learn)
        self.learner_.reset(rng)
        self.busy_low_ = np.zeros(self.scenario.n_robots, dtype=bool)
        self.initial_space_ = self.learning_space()

    def begin_set(self, set_index: int, learning: bool) -> None:
        self.learner_.begin_set(learning)
        self.busy_low_[:] = False

    def end_set(self) -> None:
        """Close every open decision as terminal: the set is an episode."""
        self.learner_.end_set()
        self.busy_low_[:] = False

    # -- what the robots may do --------------------------------------------------------------
    def willing(self) -> np.ndarray:
        """(m, n) robots that can and will do each type (QL-MRTA: all capable ones)."""
        return self.capable

    def allowed(self) -> np.ndarray:
        """(m, n) robots that may be given each type in a round (QL-MRTA: the willing ones)."""
        return self.willing()

    def learning_space(self) -> np.ndarray:
        """Per-robot learning-space dimension 2 * n_j**h for the current alphabets."""
        return self.learner_.learning_space()

    def task_abandoned(self, robot: int, task_type: int) -> None:
        """Robot ``robot`` broke down and gave up its task: it is no longer busy with a low one
        (no penalty for high tasks lost while it is broken). Its Q-learning is unchanged."""
        self.busy_low_[robot] = False

    # -- hooks ExpT-MRTA overrides -----------------------------------------------------------
    def _bid_divisor(self) -> np.ndarray:
        return np.ones(self.capable.shape)

    def _reward_scale(self, j: int, task_type: int, action: int) -> float:
        return 1.0

    def _after_auction(self, batch: Batch, bids: np.ndarray, assignment: np.ndarray) -> None:
        """Nothing to learn from the auction itself in QL-MRTA."""

    def _restructure(self) -> None:
        """QL-MRTA never changes a robot's task set."""

    def _second_round(
        self,
        state: WorldState,
        batch: Batch,
        costs: np.ndarray,
        assignment: np.ndarray,
        bids: np.ndarray,
    ) -> None:
        """QL-MRTA has no second auction (ExpT-MRTA's reserve rule has one)."""

    # -- one round ---------------------------------------------------------------------------
    def allocate(
        self, state: WorldState, batch: Batch, costs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Decide, bid, run the auction and learn from it; return (assignment, bids)."""
        self.busy_low_ &= ~state.free
        learner = self.learner_
        willing = self.willing()
        divisor = self._bid_divisor()
        m, k = costs.shape
        bids = np.full((m, k), np.inf)
        decisions: list[list[tuple[int, int, int, float]]] = [[] for _ in range(m)]
        for j in range(m):
            for t in range(k):
                i = int(batch.types[t])
                if not willing[j, i]:
                    continue
                learner.push(j, i)
                if not state.free[j]:
                    continue
                if not batch.high[t]:
                    s, a = learner.decide(j)
                    decisions[j].append((s, a, t, self._reward_scale(j, i, a)))
                    if a == WAIT:
                        continue
                bids[j, t] = costs[j, t] / divisor[j, i]
        assignment = solve_priority_assignment(bids, batch.high)
        self._after_auction(batch, bids, assignment)
        if learner.learning_:
            self._learn(batch, assignment, decisions, willing)
        primary = assignment.copy()
        self._second_round(state, batch, costs, assignment, bids)
        if learner.learning_:
            self._restructure()
        self._mark_busy(batch, primary)
        return assignment, bids

    def _mark_busy(self, batch: Batch, assignment: np.ndarray) -> None:
        for t in np.flatnonzero(assignment >= 0):
            self.busy_low_[assignment[t]] = not batch.high[t]

    def _learn(self, batch: Batch, assignment: np.ndarray, decisions, willing: np.ndarray) -> None:
        p, learner = self.learn, self.learner_
        lost_high_types = batch.types[(assignment < 0) & batch.high]
        for i in lost_high_types:
            for j in np.flatnonzero(self.busy_low_ & willing[:, i]):
                learner.credit(j, -p.penalty_lost_high)
        won = {int(assignment[t]): t for t in np.flatnonzero(assignment >= 0)}
        for j, decs in enumerate(decisions):
            t_won = won.get(j, -1)
            decs.sort(key=lambda d: d[2] == t_won)  # the decision that won goes last, stays open
            for s, a, t, scale in decs:
                learner.open(j, Decision(s, a, 0.0, scale), next_state=s)
                if a == DO and t == t_won:
                    learner.credit(j, p.reward_low)
        for j, t in won.items():
            if batch.high[t]:
                learner.credit(j, p.reward_high)

    # -- reporting ---------------------------------------------------------------------------
    def experience_snapshot(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(TEM, behaviour) arrays for ExpT-MRTA; None for allocators without experience."""
        return None


def joint_log10(per_robot: np.ndarray) -> float:
    """log10 of the joint (centralised) learning space: the product over robots."""
    per_robot = np.asarray(per_robot, dtype=float)
    if (per_robot <= 0).any():
        return float("-inf")
    return float(np.log10(per_robot).sum())


__all__ = ["QLAllocator", "joint_log10", "space_size"]
