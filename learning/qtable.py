"""A robot's tabular Q-function over the history of announced task types (SPEC §3).

State: the types of the last ``h`` announced tasks the robot can do, the current one first,
over the robot's alphabet (its current task set, size n). Actions: do (0) and wait (1), so
the table has ``2 * n**h`` entries. Ties go to ``do``: an untrained robot bids like the
market baseline.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

DO, WAIT = 0, 1


def space_size(n_types: int, history: int) -> int:
    """Learning-space dimension |S| x |A| = 2 * n**h of one robot."""
    return 2 * n_types**history


class HistoryQTable:
    """Q(s, a) for one robot, with the history that defines its state."""

    def __init__(self, alphabet: Sequence[int], history: int) -> None:
        self.history = history
        self.alphabet_ = sorted(int(t) for t in alphabet)
        self.digit_ = {t: d for d, t in enumerate(self.alphabet_)}
        self.q_ = np.zeros((len(self.alphabet_) ** history, 2))
        self.recent_: list[int] = []  # most recent first, at most `history` types

    @property
    def size(self) -> int:
        return space_size(len(self.alphabet_), self.history)

    def push(self, task_type: int) -> None:
        """Record an announced task of a type in the alphabet as the current one."""
        self.recent_.insert(0, int(task_type))
        del self.recent_[self.history :]

    def state(self) -> int:
        """Index of the current state; missing history is padded with the current type."""
        return self.encode(self.recent_ + [self.recent_[0]] * (self.history - len(self.recent_)))

    def encode(self, types) -> int:
        """State index of a full history (current first) over this alphabet."""
        index = 0
        for t in types:
            index = index * len(self.alphabet_) + self.digit_[int(t)]
        return index

    def greedy(self, state: int) -> int:
        return int(np.argmax(self.q_[state]))

    def update(self, state: int, action: int, reward: float, target: float, alpha: float) -> None:
        """One Q-learning step towards ``reward + target`` (target = gamma * max Q(s', .) or 0)."""
        self.q_[state, action] += alpha * (reward + target - self.q_[state, action])

    def decode(self, states: np.ndarray) -> np.ndarray:
        """(len(states), h) array of task types for state indices (current first)."""
        n = len(self.alphabet_)
        digits = np.empty((states.size, self.history), dtype=int)
        rest = states.copy()
        for pos in range(self.history - 1, -1, -1):
            digits[:, pos] = rest % n
            rest //= n
        return np.asarray(self.alphabet_)[digits]

    def without(self, task_type: int) -> HistoryQTable:
        """A table over the alphabet minus ``task_type``; surviving states keep their values."""
        smaller = HistoryQTable([t for t in self.alphabet_ if t != task_type], self.history)
        if smaller.alphabet_:
            types = smaller.decode(np.arange(smaller.q_.shape[0]))
            old = np.zeros(types.shape[0], dtype=int)
            for pos in range(self.history):
                old = old * len(self.alphabet_) + np.vectorize(self.digit_.get)(types[:, pos])
            smaller.q_[:] = self.q_[old]
        smaller.recent_ = [t for t in self.recent_ if t != task_type]
        return smaller
