"""Gymnasium environment: the centralised view of the allocation loop.

One step is one announcement round. The observation holds every robot's state (free or busy,
seconds of work left, TEM per task type) and the announced batch padded to ``MAX_SLOTS``
slots (type, priority, validity). The action says, for every robot and slot, bid (1) or wait
(0); bids from busy robots, for empty slots or for types a robot cannot do are ignored. The
market's exact priority auction resolves the bids. The team reward follows SPEC §3:
``reward_high`` per high-priority task taken, ``reward_low`` per low-priority task taken, and
``-penalty_lost_high`` for each high-priority task lost while a robot that could have done it
was busy with a low-priority task.

An episode plays the sets of one seeded stream (all sets by default, only the learning or the
test sets, or the paper protocol: learning sets then test sets), exactly as
:func:`learning.episode.run_protocol` does. :class:`AllocationRounds` is the round mechanics
this env shares with the PettingZoo env (:mod:`learning.pz_env`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from allocation.auction import solve_priority_assignment
from allocation.costs import make_cost_model
from learning.episode import protocol_sets
from learning.experience import ExperienceModel
from learning.rounds import drain, play_round
from learning.seeding import run_generators
from sim import make_world
from sim.recording import TrajectoryRecorder
from sim.scenario import Scenario
from sim.tasks import Batch, generate_stream
from sim.world import WorldState

MAX_SLOTS = 7
BUSY_CAP_S = 1.0e6  # observation bound on seconds of work left (clipped)
SET_CHOICES = ("all", "learn", "test", "protocol")


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


class AllocationRounds:
    """Round mechanics shared by the Gymnasium and the PettingZoo env (a mixin: no API of its own).

    Public state, read by renderers and policies: ``scenario``, ``capable``, ``world``,
    ``cost_model``, ``stream_``, ``experience_`` (observed TEM, never refusing), ``batch_`` (the
    batch to decide on), ``last_assignment_``, ``announced_`` / ``allocated_`` (low, high).
    """

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "render_fps": 10}

    def _setup(self, scenario: Scenario, cost: str, sets: str, render_mode: str | None) -> None:
        self.scenario = sc = scenario
        if sc.stream.batch_max > MAX_SLOTS:
            raise ValueError(f"batch_max {sc.stream.batch_max} exceeds the env's {MAX_SLOTS} slots")
        if sets not in SET_CHOICES:
            raise ValueError(f"sets must be one of {SET_CHOICES}, got {sets!r}")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.sets = sets
        self.render_mode = render_mode
        self.capable = sc.capability_matrix()
        self.world = make_world(sc)
        self.cost_model = make_cost_model(cost, sc, getattr(self.world, "planner", None))
        self.recorder_ = None

    def _start(self, run_seed: int, sets: str | None = None) -> None:
        """Draw the stream of ``run_seed`` and stand before its first round."""
        rngs = run_generators(run_seed)
        self.stream_ = generate_stream(self.scenario, rngs.stream)
        self.world.reset(rngs.world)
        if self.render_mode == "rgb_array" and self.scenario.spatial is not None:
            self.recorder_ = TrajectoryRecorder.for_scenario(self.scenario)
            self.world.recorder = self.recorder_
        spec = self.scenario.experience
        self.experience_ = ExperienceModel(
            self.capable, type(spec)(delta_v=spec.delta_v, delta_u=0.0)
        )
        self.set_order_ = set_order(self.scenario, sets or self.sets)
        self.batches_ = iter(
            [(p, b) for p, s in enumerate(self.set_order_) for b in self.stream_.batches(s)]
        )
        self.busy_low_ = np.zeros(self.scenario.n_robots, dtype=bool)
        self.announced_ = np.zeros((2,), dtype=np.int64)  # low, high
        self.allocated_ = np.zeros((2,), dtype=np.int64)
        self.batch_ = None
        self.set_position_ = 0
        self.last_assignment_ = np.zeros(0, dtype=int)
        self._next_batch()

    def _play(self, action: np.ndarray) -> tuple[RoundOutcome, bool]:
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
                self._drain()
                self.busy_low_[:] = False
            self.batch_, self.set_position_ = batch, position
            return True
        self._drain()
        return False

    def _drain(self) -> None:
        drain(self.world, self.recorder_)

    def _slots(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(type, high, valid) of the current batch, padded to ``MAX_SLOTS``."""
        k = len(self.batch_)
        types = np.zeros(MAX_SLOTS, dtype=np.int64)
        high = np.zeros(MAX_SLOTS, dtype=np.int8)
        valid = np.zeros(MAX_SLOTS, dtype=np.int8)
        types[:k], high[:k], valid[:k] = self.batch_.types, self.batch_.high, 1
        return types, high, valid

    @staticmethod
    def _busy_s(state) -> np.ndarray:
        """Seconds of work left per robot, float32, clipped to the observation bound."""
        return np.clip(state.busy_until_s - state.time_s, 0.0, BUSY_CAP_S).astype(np.float32)

    def _info(self) -> dict[str, Any]:
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


class AllocationEnv(AllocationRounds, gym.Env):
    """``mrta/Allocation-v0``: bid/wait decisions of all robots for one announced batch a step."""

    def __init__(
        self,
        scenario: Scenario,
        cost: str = "abstract",
        sets: str = "all",
        render_mode: str | None = None,
    ) -> None:
        self._setup(scenario, cost, sets, render_mode)
        m, n = scenario.n_robots, scenario.n_types
        self.observation_space = spaces.Dict(
            {
                "free": spaces.MultiBinary(m),
                "busy_s": spaces.Box(0.0, BUSY_CAP_S, (m,), np.float32),
                "experience": spaces.Box(0.0, 2.0, (m, n), np.float32),
                "task_type": spaces.MultiDiscrete(np.full(MAX_SLOTS, n)),
                "task_high": spaces.MultiBinary(MAX_SLOTS),
                "task_valid": spaces.MultiBinary(MAX_SLOTS),
            }
        )
        self.action_space = spaces.MultiBinary((m, MAX_SLOTS))

    # -- gymnasium API -------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        run_seed = seed if seed is not None else int(self.np_random.integers(2**31))
        self._start(run_seed)
        return self._obs(), self._info()

    def step(self, action):
        sc = self.scenario
        k = len(self.batch_)
        action = np.asarray(action, dtype=bool).reshape(sc.n_robots, MAX_SLOTS)[:, :k]
        out, terminated = self._play(action)
        batch, won, p = out.batch, out.won, sc.learning
        reward = p.reward_high * float((won & batch.high).sum()) + p.reward_low * float(
            (won & ~batch.high).sum()
        )
        reward -= p.penalty_lost_high * float(
            sum(bool((out.busy_low & self.capable[:, i]).any()) for i in out.lost_high_types)
        )
        return self._obs(), reward, terminated, False, self._info()

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        from sim.render.env import env_frame

        return env_frame(self)

    def _obs(self) -> dict[str, np.ndarray]:
        types, high, valid = self._slots()
        state = self.world.snapshot()
        return {
            "free": state.free.astype(np.int8),
            "busy_s": self._busy_s(state),
            "experience": self.experience_.u_.astype(np.float32),
            "task_type": types,
            "task_high": high,
            "task_valid": valid,
        }


def market_policy(env: AllocationEnv, obs: dict[str, np.ndarray]) -> np.ndarray:
    """The market baseline as a policy: every free robot bids for every valid task it can do."""
    types = obs["task_type"]
    can = env.capable[:, types] & obs["task_valid"].astype(bool)[None, :]
    return (can & obs["free"].astype(bool)[:, None]).astype(np.int8)
