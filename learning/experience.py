"""Task experience (SPEC §4, paper §5): TEP v, TEM u and behaviours 0/1/2, for all robots at once.

Per robot j and task type i:

- eta: T_i tasks allocated to R_j so far;
- mu: expected T_i tasks for R_j, the fair share among those who bid: each T_i auction in which
  R_j bid adds 1/b (b bidders);
- TEP v = 2 / (1 + exp(-(eta - mu))) = 2 * expit(eta - mu), in (0, 2) and 1 at the start;
- TEM u = mean of the v values so far, one per T_i auction in which R_j bid (1 before any).

Behaviour 0 (regular) turns into behaviour 1 (eager/hesitant) once |v - 1| >= delta_v; a robot
refuses T_i for good (behaviour 2) once it has n_min observations and u < delta_u, unless that
would leave fewer than coverage_k willing robots for T_i or the robot with no type at all.
"""

from __future__ import annotations

import numpy as np
from scipy.special import expit

from sim.scenario import ExperienceSpec

B0_REGULAR, B1_EAGER_HESITANT, B2_REFUSED = 0, 1, 2


def tep(eta: np.ndarray | float, mu: np.ndarray | float) -> np.ndarray:
    """Task experience parameter, stable for any |eta - mu| (no overflow in exp)."""
    return 2.0 * expit(np.subtract(eta, mu, dtype=float))


class ExperienceModel:
    """TEP/TEM bookkeeping and behaviour transitions for m robots and n task types."""

    def __init__(self, capable: np.ndarray, spec: ExperienceSpec) -> None:
        self.capable = np.asarray(capable, dtype=bool)
        self.spec = spec
        shape = self.capable.shape
        self.eta_ = np.zeros(shape)
        self.mu_ = np.zeros(shape)
        self.v_ = np.ones(shape)
        self.v_sum_ = np.zeros(shape)
        self.count_ = np.zeros(shape, dtype=np.int64)
        self.behaviour_ = np.zeros(shape, dtype=np.int8)

    @property
    def u_(self) -> np.ndarray:
        """TEM: mean of the TEP values observed, 1 where there are none yet."""
        return np.divide(
            self.v_sum_, self.count_, out=np.ones_like(self.v_sum_), where=self.count_ > 0
        )

    @property
    def refused_(self) -> np.ndarray:
        return self.behaviour_ == B2_REFUSED

    @property
    def willing_(self) -> np.ndarray:
        """Robots that can and still will do each type."""
        return self.capable & ~self.refused_

    def observe_auction(self, task_type: int, bidders: np.ndarray, winner: int) -> None:
        """Update eta, mu, v and u of every robot that bid in one T_i auction."""
        if bidders.size == 0:
            return
        i = task_type
        self.mu_[bidders, i] += 1.0 / bidders.size
        if winner >= 0:
            self.eta_[winner, i] += 1.0
        v = tep(self.eta_[bidders, i], self.mu_[bidders, i])
        self.v_[bidders, i] = v
        self.v_sum_[bidders, i] += v
        self.count_[bidders, i] += 1
        regular = self.behaviour_[bidders, i] == B0_REGULAR
        knows = np.abs(v - 1.0) >= self.spec.delta_v
        if self.spec.sticky_b1:
            self.behaviour_[bidders[regular & knows], i] = B1_EAGER_HESITANT
        else:
            not_refused = ~self.refused_[bidders, i]
            self.behaviour_[bidders[not_refused], i] = np.where(
                knows[not_refused], B1_EAGER_HESITANT, B0_REGULAR
            )

    def robot_state(self, j: int, i: int) -> tuple:
        """Robot j's experience of type i: (eta, mu, v, v_sum, count, behaviour)."""
        return (
            self.eta_[j, i],
            self.mu_[j, i],
            self.v_[j, i],
            self.v_sum_[j, i],
            self.count_[j, i],
            self.behaviour_[j, i],
        )

    def set_robot_state(self, j: int, i: int, state: tuple) -> None:
        """Inverse of :meth:`robot_state`."""
        (
            self.eta_[j, i],
            self.mu_[j, i],
            self.v_[j, i],
            self.v_sum_[j, i],
            self.count_[j, i],
            self.behaviour_[j, i],
        ) = state

    def replay(self, state: tuple, auctions) -> tuple:
        """One robot's experience of one type (``state``, as :meth:`robot_state` gives it)
        after the ``auctions`` of that type it bid in (pairs (number of bidders, won)), with
        the same arithmetic as :meth:`observe_auction`; the model itself is not changed."""
        eta, mu, v, v_sum, count, behaviour = state
        for n_bidders, won in auctions:
            mu = mu + 1.0 / n_bidders
            if won:
                eta = eta + 1.0
            v = float(tep(np.array([eta]), np.array([mu]))[0])
            v_sum = v_sum + v
            count = count + 1
            knows = abs(v - 1.0) >= self.spec.delta_v
            if self.spec.sticky_b1:
                if behaviour == B0_REGULAR and knows:
                    behaviour = B1_EAGER_HESITANT
            elif behaviour != B2_REFUSED:
                behaviour = B1_EAGER_HESITANT if knows else B0_REGULAR
        return eta, mu, v, v_sum, count, behaviour

    def refusals(self) -> list[tuple[int, int]]:
        """Apply behaviour 2 where it is due; return the new (robot, type) refusals.

        Candidates are taken lowest TEM first, so when the coverage guard allows only some
        robots to drop a type, the least experienced ones drop it. A robot never refuses its
        last type: it stays in the team with at least one.
        """
        u = self.u_
        due = self.willing_ & (self.count_ >= self.spec.n_min) & (u < self.spec.delta_u)
        out = []
        for j, i in sorted(zip(*np.nonzero(due), strict=True), key=lambda ji: (u[ji], ji)):
            keeps_a_type = self.willing_[j].sum() > 1
            if keeps_a_type and self.willing_[:, i].sum() - 1 >= self.spec.coverage_k:
                self.behaviour_[j, i] = B2_REFUSED
                out.append((int(j), int(i)))
        return out

    def bid_scale(self) -> np.ndarray:
        """Divisor of the cost in a bid (eq. 8): u in behaviour 1, 1 otherwise."""
        return np.where(self.behaviour_ == B1_EAGER_HESITANT, self.u_, 1.0)
