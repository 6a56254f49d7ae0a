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
:func:`learning.episode.run_protocol` does. The round itself is a
:class:`learning.env_rounds.RoundEngine` the env holds (``env.rounds``), as the PettingZoo env
(:mod:`learning.pz_env`) does.
"""

from __future__ import annotations

from typing import ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from learning.env_rounds import (
    BUSY_CAP_S,
    MAX_SLOTS,
    RENDER_MODES,
    SET_CHOICES,
    RoundEngine,
    RoundOutcome,
    check_render_mode,
    set_order,
    shows_engine,
)
from sim.scenario import Scenario

__all__ = [
    "BUSY_CAP_S",
    "MAX_SLOTS",
    "SET_CHOICES",
    "AllocationEnv",
    "RoundEngine",
    "RoundOutcome",
    "market_policy",
    "set_order",
]


@shows_engine
class AllocationEnv(gym.Env):
    """``mrta/Allocation-v0``: bid/wait decisions of all robots for one announced batch a step.

    Args:
        scenario: the scenario; cost: the cost model robots bid with; sets: which sets an
            episode plays (all, learn, test, protocol); render_mode: None or "rgb_array".

    Attributes:
        rounds: the :class:`~learning.env_rounds.RoundEngine` playing the rounds; its
            ``scenario``, ``capable``, ``world``, ``batch_``, ``experience_`` ... are shown
            on the env too.
    """

    metadata: ClassVar[dict] = {"render_modes": list(RENDER_MODES), "render_fps": 10}

    def __init__(
        self,
        scenario: Scenario,
        cost: str = "abstract",
        sets: str = "all",
        render_mode: str | None = None,
    ) -> None:
        check_render_mode(render_mode)
        self.render_mode = render_mode
        self.rounds = RoundEngine(scenario, cost, sets, record=render_mode == "rgb_array")
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
        self.rounds.start(run_seed)
        return self._obs(), self.rounds.info()

    def step(self, action):
        sc = self.scenario
        k = len(self.batch_)
        action = np.asarray(action, dtype=bool).reshape(sc.n_robots, MAX_SLOTS)[:, :k]
        out, terminated = self.rounds.play(action)
        batch, won, p = out.batch, out.won, sc.learning
        reward = p.reward_high * float((won & batch.high).sum()) + p.reward_low * float(
            (won & ~batch.high).sum()
        )
        reward -= p.penalty_lost_high * float(
            sum(bool((out.busy_low & self.capable[:, i]).any()) for i in out.lost_high_types)
        )
        return self._obs(), reward, terminated, False, self.rounds.info()

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        return self.rounds.frame()

    def _obs(self) -> dict[str, np.ndarray]:
        types, high, valid = self.rounds.slots()
        state = self.world.snapshot()
        return {
            "free": state.free.astype(np.int8),
            "busy_s": self.rounds.busy_s(state),
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
