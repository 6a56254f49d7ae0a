"""ExpT-MRTA (SPEC §4, paper §5): QL-MRTA plus task experience.

Robots that win more of a type than their fair share become eager (bid = cost / u with u > 1),
those that win less become hesitant (u < 1), and at last refuse the type for good: they stop
bidding for it, it leaves their alphabet and their Q-table is rebuilt on the smaller space.
Experience is learned on the learning sets and frozen, like the Q-tables, on the test sets.
"""

from __future__ import annotations

import numpy as np

from allocation.auction import solve_priority_assignment
from learning.experience import B1_EAGER_HESITANT, B2_REFUSED, ExperienceModel
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
        # robot -> (type, experience before the round it won in, that round's T_i auctions it
        # bid in as (bidders, won)): what task_abandoned needs to withhold the win
        self.credit_: dict[int, tuple[int, tuple, list[tuple[int, bool]]]] = {}
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

    def allocate(
        self, state: WorldState, batch: Batch, costs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        for j in np.flatnonzero(state.free).tolist():  # its last task ended: nothing to withhold
            self.credit_.pop(j, None)
        return super().allocate(state, batch, costs)

    def _after_auction(self, batch: Batch, bids: np.ndarray, assignment: np.ndarray) -> None:
        if not self.learner_.learning_:
            return
        exp = self.experience_
        won = {int(assignment[t]): int(batch.types[t]) for t in np.flatnonzero(assignment >= 0)}
        before = {j: exp.robot_state(j, i) for j, i in won.items()}
        seen: dict[int, list[tuple[int, bool]]] = {j: [] for j in won}
        for t in range(len(batch)):
            bidders = np.flatnonzero(np.isfinite(bids[:, t]))
            i, winner = int(batch.types[t]), int(assignment[t])
            exp.observe_auction(i, bidders, winner)
            self.auctions_ += 1
            for j in bidders.tolist():
                if won.get(j) == i:
                    seen[j].append((bidders.size, winner == j))
        for j, i in won.items():
            self.credit_[j] = (i, before[j], seen[j])

    def task_abandoned(self, robot: int, task_type: int) -> None:
        """Robot ``robot`` broke before finishing its ``task_type`` task: its experience of the
        type becomes what it would be had it bid in that round and not won (eta without the
        win, the TEP values of the round recomputed, the TEM with them). A refusal that was
        made meanwhile stands. Nothing to withhold for a win on a test set (experience is
        frozen) or in the reserve rule's second auction (not credited)."""
        super().task_abandoned(robot, task_type)
        credit = self.credit_.pop(robot, None)
        if credit is None or credit[0] != task_type:
            return
        i, before, auctions = credit
        exp = self.experience_
        refused = exp.behaviour_[robot, i] == B2_REFUSED
        withheld = [(n, False) for n, _ in auctions]
        exp.set_robot_state(robot, i, exp.replay(before, withheld))
        if refused:
            exp.behaviour_[robot, i] = B2_REFUSED

    def _restructure(self) -> None:
        for j, i in self.experience_.refusals():
            self.learner_.drop_type(j, i)
            self.refusal_log_.append((self.auctions_, j, i))

    def experience_snapshot(self) -> tuple[np.ndarray, np.ndarray]:
        return self.experience_.u_, self.experience_.behaviour_.copy()
