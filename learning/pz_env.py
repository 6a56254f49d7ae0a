"""PettingZoo ``ParallelEnv``: every robot is an agent deciding, per announced task, bid or wait.

One step is one announcement round, as in the Gymnasium env (both hold a
:class:`learning.env_rounds.RoundEngine`, ``env.rounds``). Agents are the robots, named as in the
scenario.
Agent j observes only itself and the batch:

- ``position``: its (x, y) in m from the world snapshot in a spatial scenario, zeros in the
  abstract world;
- ``free`` (0/1) and ``busy_s`` (seconds of work left);
- ``experience``: its TEM per task type (observed, never refusing; 1 before any auction);
- ``task_type``, ``task_high``, ``task_valid``: the batch padded to ``MAX_SLOTS`` slots, slot t
  being the batch's task t for every agent; ``task_valid[t]`` is 1 only for tasks it can do (the
  type and priority of the others read 0).

Its action is ``MultiBinary(MAX_SLOTS)``: bid (1) or wait (0) for each slot. Bids of busy robots
and for slots that are not valid for them are ignored; the market's exact priority auction
(:func:`allocation.auction.solve_priority_assignment`) resolves the rest, each robot bidding its
cost. Rewards are the per-robot rewards of QL-MRTA (:mod:`learning.qlmrta`): ``+reward_high``
for a high-priority task won, ``+reward_low`` for a low-priority task won, and
``-penalty_lost_high`` for every high-priority task of a type it can do that is lost while it is
busy with a low-priority task. Each agent's info says which slot it won (``won``, -1 if none)
and carries the team counts of the Gymnasium env's info.

The episode plays the sets of one seeded stream (``sets``: all, learn, test or protocol); at
its end every agent terminates at once. ``pettingzoo`` is an optional dependency
(``pip install 'expt-mrta[marl]'``).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding

try:
    from pettingzoo import ParallelEnv
except ImportError as exc:  # pragma: no cover - depends on the installed extras
    raise ImportError(
        "learning.pz_env needs PettingZoo: pip install 'expt-mrta[marl]' (pettingzoo>=1.24)"
    ) from exc

from learning.env_rounds import (
    BUSY_CAP_S,
    MAX_SLOTS,
    RENDER_MODES,
    RoundEngine,
    RoundOutcome,
    check_render_mode,
    shows_engine,
)
from sim.scenario import Scenario


@shows_engine
class AllocationParallelEnv(ParallelEnv):
    """``mrta_allocation_v0``: the allocation round as a parallel multi-agent game.

    Args:
        scenario: the scenario; cost: the cost model robots bid with; sets: which sets an
            episode plays (all, learn, test, protocol); render_mode: None or "rgb_array".

    Attributes:
        rounds: the :class:`~learning.env_rounds.RoundEngine` playing the rounds; its
            ``scenario``, ``capable``, ``world``, ``batch_``, ``experience_`` ... are shown
            on the env too.
    """

    metadata: ClassVar[dict] = {
        "name": "mrta_allocation_v0",
        "render_modes": list(RENDER_MODES),
        "render_fps": 10,
    }

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
        self.possible_agents = [r.name for r in scenario.robots]
        self.agents: list[str] = []
        self.agent_index = {a: j for j, a in enumerate(self.possible_agents)}
        if scenario.spatial is not None:
            self._pos_high = np.array(
                [scenario.spatial.width_m, scenario.spatial.height_m], dtype=np.float32
            )
        else:
            self._pos_high = np.zeros(2, dtype=np.float32)
        self._obs_spaces: dict[str, spaces.Space] = {}
        self._act_spaces: dict[str, spaces.Space] = {}
        self._np_random: np.random.Generator | None = None

    # -- spaces (one object per agent, built on first use: 1000 agents cost nothing upfront) ----
    def observation_space(self, agent: str) -> spaces.Space:
        if agent not in self._obs_spaces:
            self._check_agent(agent)
            n = self.scenario.n_types
            self._obs_spaces[agent] = spaces.Dict(
                {
                    "position": spaces.Box(0.0, self._pos_high, (2,), np.float32),
                    "free": spaces.Discrete(2),
                    "busy_s": spaces.Box(0.0, BUSY_CAP_S, (1,), np.float32),
                    "experience": spaces.Box(0.0, 2.0, (n,), np.float32),
                    "task_type": spaces.MultiDiscrete(np.full(MAX_SLOTS, n)),
                    "task_high": spaces.MultiBinary(MAX_SLOTS),
                    "task_valid": spaces.MultiBinary(MAX_SLOTS),
                }
            )
        return self._obs_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space:
        if agent not in self._act_spaces:
            self._check_agent(agent)
            self._act_spaces[agent] = spaces.MultiBinary(MAX_SLOTS)
        return self._act_spaces[agent]

    @property
    def np_random(self) -> np.random.Generator:
        """The env's generator (seeded by ``reset(seed=...)``), as in Gymnasium."""
        if self._np_random is None:
            self._np_random, _ = seeding.np_random()
        return self._np_random

    # -- PettingZoo API ------------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        """Start an episode; ``options={"sets": "test"}`` overrides the constructor's sets."""
        if seed is not None:
            self._np_random, _ = seeding.np_random(seed)
        run_seed = seed if seed is not None else int(self.np_random.integers(2**31))
        self.rounds.start(run_seed, (options or {}).get("sets"))
        self.agents = list(self.possible_agents)
        won = np.full(len(self.agents), -1)
        return self._observations(), self._infos(won)

    def step(self, actions: dict[str, Any]):
        """Bids of the agents for this round's slots; a missing agent waits on every slot."""
        if not self.agents:
            raise RuntimeError("step() after the episode ended; call reset()")
        m, k = self.scenario.n_robots, len(self.batch_)
        bid = np.zeros((m, k), dtype=bool)
        for agent, action in actions.items():
            a = np.asarray(action).reshape(-1)
            if a.size != MAX_SLOTS:
                raise ValueError(f"{agent}: action must have {MAX_SLOTS} entries, got {a.size}")
            self._check_agent(agent)
            bid[self.agent_index[agent]] = a[:k].astype(bool)
        out, done = self.rounds.play(bid)
        rewards = self.agent_rewards(out)
        won = np.full(m, -1)
        won[out.assignment[out.won]] = np.flatnonzero(out.won)
        agents = self.agents
        obs, infos = self._observations(), self._infos(won)
        rew = {a: float(rewards[j]) for j, a in enumerate(agents)}
        terminations = dict.fromkeys(agents, done)
        truncations = dict.fromkeys(agents, False)
        if done:
            self.agents = []
        return obs, rew, terminations, truncations, infos

    def render(self):
        """The current frame as an (H, W, 3) uint8 array (the GIF's frames in spatial worlds)."""
        if self.render_mode != "rgb_array":
            return None
        return self.rounds.frame()

    def close(self) -> None:
        """Nothing to release."""

    # -- helpers -------------------------------------------------------------------------------
    def _check_agent(self, agent: str) -> None:
        if agent not in self.agent_index:
            names = ", ".join(self.possible_agents[:5])
            raise KeyError(f"unknown agent {agent!r}; the agents are the robots ({names}, ...)")

    def agent_rewards(self, out: RoundOutcome) -> np.ndarray:
        """(m,) QL-MRTA rewards of one round (see the module docstring)."""
        p, batch = self.scenario.learning, out.batch
        reward = np.zeros(self.scenario.n_robots)
        won = out.won
        reward[out.assignment[won & batch.high]] += p.reward_high
        reward[out.assignment[won & ~batch.high]] += p.reward_low
        for i in out.lost_high_types:
            reward[out.busy_low & self.capable[:, i]] -= p.penalty_lost_high
        return reward

    def _observations(self) -> dict[str, dict[str, Any]]:
        state = self.world.snapshot()
        types, high, valid = self.rounds.slots()
        can = self.capable[:, types] & valid.astype(bool)[None, :]  # (m, MAX_SLOTS)
        own_types = np.where(can, types[None, :], 0)
        own_high = (can & high.astype(bool)[None, :]).astype(np.int8)
        own_valid = can.astype(np.int8)
        busy = self.rounds.busy_s(state)[:, None]
        u = self.experience_.u_.astype(np.float32)
        if state.positions is None:
            pos = np.zeros((self.scenario.n_robots, 2), dtype=np.float32)
        else:
            pos = np.clip(np.asarray(state.positions, dtype=np.float32), 0.0, self._pos_high)
        free = state.free.astype(np.int64)
        return {
            a: {
                "position": pos[j],
                "free": free[j],
                "busy_s": busy[j],
                "experience": u[j],
                "task_type": own_types[j],
                "task_high": own_high[j],
                "task_valid": own_valid[j],
            }
            for j, a in enumerate(self.agents)
        }

    def _infos(self, won: np.ndarray) -> dict[str, dict[str, Any]]:
        team = self.rounds.info()
        return {a: {**team, "won": int(won[j])} for j, a in enumerate(self.agents)}


def always_bid(obs: dict[str, dict[str, Any]]) -> dict[str, np.ndarray]:
    """The market baseline as a joint policy: bid for every valid slot (busy robots' bids are
    ignored by the env anyway)."""
    return {a: o["task_valid"].astype(np.int8) for a, o in obs.items()}
