"""QL-MRTA's learners (SPEC §3): one tabular Q-learner per robot, deciding do or wait.

Robot j keeps a :class:`learning.qtable.HistoryQTable` over the last ``h`` announced types it
can do. On a low-priority task, while free, it chooses do (bid) or wait epsilon-greedily; the
decision stays open, collecting the rewards credited to the robot, until the robot's next
decision closes it with the target ``gamma * max Q(s', .)``, or the end of the set closes it as
terminal. Epsilon decays once per learning set; on test sets the tables are frozen and the
choice is greedy. One generator drives every robot's exploration, robot by robot, in the order
the callers ask.

:class:`QLearners` is used by composition by :class:`learning.qlmrta.QLAllocator` (and so
ExpT-MRTA, which also drops refused types from a robot's table) and by the PettingZoo team
:class:`learning.pz_train.QLTeam`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from learning.qtable import HistoryQTable
from sim.scenario import LearningSpec


@dataclass(slots=True)
class Decision:
    """A do/wait decision whose reward is still accruing."""

    state: int
    action: int
    reward: float = 0.0
    reward_scale: float = 1.0  # ExpT eq. (9) factor fixed at decision time (1 for QL-MRTA)


class QLearners:
    """Independent tabular Q-learners, one per robot (row of ``capable``).

    Learned state: ``tables_`` (one Q-table per robot), ``pending_`` (each robot's open
    decision or None), ``epsilon_``, ``learning_sets_seen_``, ``learning_`` and the exploration
    generator ``rng_``.
    """

    def __init__(self, capable: np.ndarray, spec: LearningSpec) -> None:
        self.capable = np.asarray(capable, dtype=bool)
        self.spec = spec

    def reset(self, rng: np.random.Generator) -> None:
        """Forget everything: empty tables over each robot's task set; ``rng`` explores."""
        self.rng_ = rng
        h = self.spec.history
        self.tables_ = [HistoryQTable(np.flatnonzero(row), h) for row in self.capable]
        self.pending_: list[Decision | None] = [None] * len(self.tables_)
        self.learning_ = True
        self.epsilon_ = self.spec.epsilon_start
        self.learning_sets_seen_ = 0

    def begin_set(self, learning: bool) -> None:
        """Start a set; epsilon decays once per learning set."""
        self.learning_ = learning
        if learning:
            p = self.spec
            decayed = p.epsilon_start * p.epsilon_decay**self.learning_sets_seen_
            self.epsilon_ = max(p.epsilon_end, decayed)
            self.learning_sets_seen_ += 1

    def end_set(self) -> None:
        """Close every open decision as terminal: the set is an episode."""
        for j, pend in enumerate(self.pending_):
            if pend is not None and self.learning_:
                self.close(j, pend, target=0.0)
            self.pending_[j] = None

    def push(self, j: int, task_type: int) -> None:
        """Robot j saw an announced task of a type it does: it becomes its current type."""
        self.tables_[j].push(task_type)

    def decide(self, j: int) -> tuple[int, int]:
        """(state, action) of robot j now: epsilon-greedy while learning, greedy otherwise."""
        table = self.tables_[j]
        s = table.state()
        if self.learning_ and self.rng_.random() < self.epsilon_:
            return s, int(self.rng_.integers(2))
        return s, table.greedy(s)

    def open(self, j: int, decision: Decision, next_state: int) -> None:
        """Make ``decision`` robot j's open one, closing the previous towards ``next_state``."""
        old = self.pending_[j]
        if old is not None:
            target = self.spec.gamma * float(self.tables_[j].q_[next_state].max())
            self.close(j, old, target)
        self.pending_[j] = decision

    def credit(self, j: int, reward: float) -> None:
        """Add ``reward`` to robot j's open decision, if it has one."""
        if self.pending_[j] is not None:
            self.pending_[j].reward += reward

    def close(self, j: int, decision: Decision, target: float) -> None:
        """One Q-learning step for a finished decision (``target`` 0 when terminal)."""
        reward = decision.reward * decision.reward_scale
        self.tables_[j].update(decision.state, decision.action, reward, target, self.spec.alpha)

    def drop_type(self, j: int, task_type: int) -> None:
        """Robot j refused ``task_type``: rebuild its table on the smaller alphabet.

        Surviving states keep their values. The open decision is re-encoded in the new table,
        or dropped when its state involved the refused type (or no type is left).
        """
        old = self.tables_[j]
        new = old.without(task_type)
        pend = self.pending_[j]
        if pend is not None:
            kept = old.decode(np.array([pend.state]))[0]
            if task_type in kept or not new.alphabet_:
                self.pending_[j] = None
            else:
                pend.state = new.encode(kept)
        self.tables_[j] = new

    def learning_space(self) -> np.ndarray:
        """Per-robot learning-space dimension 2 * n_j**h for the current alphabets."""
        return np.array([t.size for t in self.tables_], dtype=np.int64)
