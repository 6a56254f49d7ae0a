"""The allocation round of the environments: one object the Gymnasium and PettingZoo envs hold.

:class:`RoundEngine` owns a run's world, cost model and seeded stream (built by
:mod:`learning.assembly`, as the experiment protocol builds them), plays one announcement
round from a bid matrix (the market's exact priority auction resolves the bids, through
:func:`learning.rounds.play_round`, the one door every loop uses), and keeps the team counts
and the experience the observations show. The environments compose it; they add only their
spaces, observations and rewards.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np

from allocation.auction import solve_priority_assignment
from learning.assembly import build_world, seeded_stream
from learning.episode import protocol_sets
from learning.experience import ExperienceModel
from learning.rounds import drain, play_round
from sim.recording import TrajectoryRecorder
from sim.scenario import Scenario
from sim.tasks import Batch
from sim.world import WorldState

MAX_SLOTS = 7
BUSY_CAP_S = 1.0e6  # observation bound on seconds of work left (clipped)
SET_CHOICES = ("all", "learn", "test", "protocol")
RENDER_MODES = ("rgb_array",)


def set_order(scenario: Scenario, sets: str) -> list[int]:
    """Zero-based set indices an episode plays: all, learn, test, or protocol (learn then test)."""
    learn, test = protocol_sets(scenario)
    everything = list(range(scenario.stream.n_sets))
    return {"all": everything, "learn": learn, "test": test, "protocol": learn + test}[sets]


@dataclass(frozen=True, slots=True)
class RoundOutcome:
    """What one announcement round did, for the envs to turn into rewards."""

    batch: Batch
    assignment: np.ndarray  # (k,) robot per task, -1 = lost
    bid: np.ndarray  # (m, k) bool: bids the auction saw
    busy_low: np.ndarray  # (m,) robots busy with a low-priority task when the round began

    @property
    def won(self) -> np.ndarray:
        return self.assignment >= 0

    @property
    def lost_high_types(self) -> np.ndarray:
        return self.batch.types[~self.won & self.batch.high]


class RoundEngine:
    """The rounds of one scenario's episodes, played from bid matrices.

    Args:
        scenario: the scenario (its ``batch_max`` must fit ``MAX_SLOTS``).
        cost: the cost model robots bid with (``abstract``, ``distance``, ``time``).
        sets: which sets an episode plays: all, learn, test or protocol (learn then test).
        record: keep a trajectory recorder in a spatial world (for ``rgb_array`` frames).

    Attributes (read by environments, renderers and policies):
        scenario, capable ((m, n) bool), world, cost_model, sets.
        stream_: the episode's task stream; experience_: observed TEM (never refusing).
        batch_: the batch to decide on; last_assignment_: the last round's.
        announced_, allocated_: (2,) tasks announced and allocated so far (low, high).
        recorder_: the trajectory recorder, or None.
    """

    def __init__(self, scenario: Scenario, cost: str, sets: str, record: bool = False) -> None:
        if scenario.stream.batch_max > MAX_SLOTS:
            raise ValueError(
                f"batch_max {scenario.stream.batch_max} exceeds the env's {MAX_SLOTS} slots"
            )
        if sets not in SET_CHOICES:
            raise ValueError(f"sets must be one of {SET_CHOICES}, got {sets!r}")
        self.scenario, self.sets, self.record = scenario, sets, record
        self.capable = scenario.capability_matrix()
        self.world, self.cost_model = build_world(scenario, cost)
        self.recorder_: TrajectoryRecorder | None = None
        self.batch_: Batch | None = None

    def start(self, run_seed: int, sets: str | None = None) -> None:
        """Draw the stream of ``run_seed`` and stand before its first round."""
        sc = self.scenario
        self.stream_, rngs = seeded_stream(sc, run_seed)
        self.world.reset(rngs.world)
        if self.record and sc.spatial is not None:
            self.recorder_ = TrajectoryRecorder.for_scenario(sc)
            self.world.recorder = self.recorder_
        spec = sc.experience
        self.experience_ = ExperienceModel(
            self.capable, type(spec)(delta_v=spec.delta_v, delta_u=0.0)
        )
        self.set_order_ = set_order(sc, sets or self.sets)
        self.batches_ = iter(
            [(p, b) for p, s in enumerate(self.set_order_) for b in self.stream_.batches(s)]
        )
        self.busy_low_ = np.zeros(sc.n_robots, dtype=bool)
        self.announced_ = np.zeros((2,), dtype=np.int64)  # low, high
        self.allocated_ = np.zeros((2,), dtype=np.int64)
        self.batch_ = None
        self.set_position_ = 0
        self.last_assignment_ = np.zeros(0, dtype=int)
        self._next_batch()

    def play(self, action: np.ndarray) -> tuple[RoundOutcome, bool]:
        """Resolve one round from an (m, k) bool bid matrix; return (outcome, terminated)."""
        batch = self.batch_
        played = play_round(
            self.world,
            batch,
            self.cost_model,
            partial(self._auction, action),
            self.scenario.stream.announce_interval_s,
            self.recorder_,
        )
        assignment = played.assignment
        won = assignment >= 0
        self.busy_low_ &= ~played.state.free
        busy_low = self.busy_low_.copy()
        np.add.at(self.announced_, batch.high.astype(int), 1)
        np.add.at(self.allocated_, batch.high[won].astype(int), 1)
        self.busy_low_[assignment[won]] = ~batch.high[won]
        self.last_assignment_ = assignment
        terminated = not self._next_batch()
        return RoundOutcome(batch, assignment, played.bids, busy_low), terminated

    def _auction(
        self, action: np.ndarray, state: WorldState, batch: Batch, costs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The round's ``decide``: the agents' bids (free robots, finite costs) resolved by the
        market's priority auction; every auction is observed by the experience model."""
        bid = action & state.free[:, None] & np.isfinite(costs)
        assignment = solve_priority_assignment(np.where(bid, costs, np.inf), batch.high)
        for t in range(len(batch)):
            self.experience_.observe_auction(
                int(batch.types[t]), np.flatnonzero(bid[:, t]), int(assignment[t])
            )
        return assignment, bid

    def _next_batch(self) -> bool:
        """Advance to the next non-empty round; drain the world between sets."""
        previous = self.batch_
        for position, batch in self.batches_:
            if previous is not None and position != self.set_position_:
                drain(self.world, self.recorder_)
                self.busy_low_[:] = False
            self.batch_, self.set_position_ = batch, position
            return True
        drain(self.world, self.recorder_)
        return False

    def slots(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(type, high, valid) of the current batch, padded to ``MAX_SLOTS``."""
        k = len(self.batch_)
        types = np.zeros(MAX_SLOTS, dtype=np.int64)
        high = np.zeros(MAX_SLOTS, dtype=np.int8)
        valid = np.zeros(MAX_SLOTS, dtype=np.int8)
        types[:k], high[:k], valid[:k] = self.batch_.types, self.batch_.high, 1
        return types, high, valid

    @staticmethod
    def busy_s(state: WorldState) -> np.ndarray:
        """Seconds of work left per robot, float32, clipped to the observation bound."""
        return np.clip(state.busy_until_s - state.time_s, 0.0, BUSY_CAP_S).astype(np.float32)

    def info(self) -> dict:
        """The team's counts: set and round, tasks announced and allocated, completion."""
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = self.allocated_ / self.announced_
        return {
            "set": int(self.batch_.set_index),
            "round": int(self.batch_.round_index),
            "set_position": int(self.set_position_),  # index into the episode's set order
            "announced": {"low": int(self.announced_[0]), "high": int(self.announced_[1])},
            "allocated": {"low": int(self.allocated_[0]), "high": int(self.allocated_[1])},
            "completion": {"low": float(ratio[0]), "high": float(ratio[1])},
        }

    def frame(self, size: tuple[int, int] | None = None) -> np.ndarray:
        """The current frame, (H, W, 3) uint8 (``sim.render.env.env_frame``)."""
        from sim.render.env import FRAME_SIZE, env_frame

        return env_frame(self.world, self.batch_, self.scenario, self.recorder_, size or FRAME_SIZE)


def check_render_mode(render_mode: str | None) -> None:
    """ValueError unless ``render_mode`` is None or one the envs draw."""
    if render_mode not in (None, *RENDER_MODES):
        raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")


ENGINE_VIEWS = (
    "scenario",
    "capable",
    "world",
    "cost_model",
    "sets",
    "stream_",
    "experience_",
    "batch_",
    "last_assignment_",
    "announced_",
    "allocated_",
    "recorder_",
)


def shows_engine(cls: type) -> type:
    """Class decorator: read-only properties for the :data:`ENGINE_VIEWS` of the environment's
    ``rounds`` (a :class:`RoundEngine`), so policies and renderers read ``env.capable`` as
    before the engine was an object of its own."""
    for name in ENGINE_VIEWS:
        view = property(lambda self, n=name: getattr(self.rounds, n))
        view.__doc__ = f"The round engine's ``{name}`` (:class:`RoundEngine`)."
        setattr(cls, name, view)
    return cls


__all__ = [
    "BUSY_CAP_S",
    "ENGINE_VIEWS",
    "MAX_SLOTS",
    "SET_CHOICES",
    "RoundEngine",
    "RoundOutcome",
    "check_render_mode",
    "set_order",
    "shows_engine",
]
