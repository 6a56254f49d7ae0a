"""ExpT-MRTA (SPEC §4, paper §5): QL-MRTA plus task experience.

Robots that win more of a type than their fair share become eager (bid = cost / u with u > 1),
those that win less become hesitant (u < 1), and at last refuse the type for good: they stop
bidding for it, it leaves their alphabet and their Q-table is rebuilt on the smaller space.
Experience is learned on the learning sets and frozen, like the Q-tables, on the test sets.
"""

from __future__ import annotations

import numpy as np

from allocation.auction import solve_priority_assignment
from learning.experience import B1_EAGER_HESITANT, ExperienceModel
from learning.qlmrta import QLAllocator
from learning.qtable import DO
from sim.tasks import Batch
from sim.world import WorldState


class ExpTAllocator(QLAllocator):
    """ExpT-MRTA: experience-shaped bids and rewards, refusal shrinking the Q-space."""

    name = "expt"

    def reset(self, rng: np.random.Generator) -> None:
        self.experience_ = ExperienceModel(self.capable, self.scenario.experience)
        self.refusal_log_: list[tuple[int, int, int]] = []  # (auction count, robot, type)
        self.auctions_ = 0
        super().reset(rng)

    def willing(self) -> np.ndarray:
        return self.experience_.willing_

    def allowed(self) -> np.ndarray:
        """Willing robots; under the reserve rule every capable robot (refused: as reserve)."""
        if self.scenario.experience.refusal == "reserve":
            return self.capable
        return self.experience_.willing_

    def _second_round(
        self,
        state: WorldState,
        batch: Batch,
        costs: np.ndarray,
        assignment: np.ndarray,
        bids: np.ndarray,
    ) -> None:
        """Reserve rule: tasks no willing robot took go to free robots that refused the type.

        Reserve robots bid their plain cost (no experience scaling: they have none left for
        the type) in a second priority auction over the tasks still open and the robots not
        given a task in this round. ``assignment`` and ``bids`` are completed in place.
        """
        if self.scenario.experience.refusal != "reserve":
            return
        open_tasks = np.flatnonzero(assignment < 0)
        if open_tasks.size == 0:
            return
        reserve = self.capable & self.experience_.refused_
        taken = np.zeros(len(state.free), dtype=bool)
        taken[assignment[assignment >= 0]] = True
        free = state.free & ~taken
        types = batch.types[open_tasks]
        ok = reserve[:, types] & free[:, None]
        if not ok.any():
            return
        second = np.where(ok, costs[:, open_tasks], np.inf)
        won = solve_priority_assignment(second, batch.high[open_tasks])
        got = won >= 0
        assignment[open_tasks[got]] = won[got]
        bids[won[got], open_tasks[got]] = second[won[got], np.flatnonzero(got)]

    def _bid_divisor(self) -> np.ndarray:
        return self.experience_.bid_scale()

    def _reward_scale(self, j: int, task_type: int, action: int) -> float:
        """Eq. (9): u * r for do, r / u for wait, in behaviour 1; 1 otherwise."""
        if self.experience_.behaviour_[j, task_type] != B1_EAGER_HESITANT:
            return 1.0
        u = float(self.experience_.u_[j, task_type])
        return u if action == DO else 1.0 / u

    def _after_auction(self, batch: Batch, bids: np.ndarray, assignment: np.ndarray) -> None:
        if not self.learner_.learning_:
            return
        for t in range(len(batch)):
            bidders = np.flatnonzero(np.isfinite(bids[:, t]))
            self.experience_.observe_auction(int(batch.types[t]), bidders, int(assignment[t]))
            self.auctions_ += 1

    def _restructure(self) -> None:
        for j, i in self.experience_.refusals():
            self.learner_.drop_type(j, i)
            self.refusal_log_.append((self.auctions_, j, i))

    def experience_snapshot(self) -> tuple[np.ndarray, np.ndarray]:
        return self.experience_.u_, self.experience_.behaviour_.copy()
