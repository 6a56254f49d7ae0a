"""QL-MRTA learners trained through the PettingZoo env: a worked multi-agent example.

Every robot is an independent tabular learner (:class:`learning.learner.QLearners`) that
sees only its own observation: the announced tasks it can do, whether it is free, and its own
reward. It follows QL-MRTA exactly (:mod:`learning.qlmrta`): it always bids on high-priority
tasks, chooses ``do`` (bid) or ``wait`` epsilon-greedily on low-priority ones while free, and
credits each decision with the rewards it receives until its next decision. Played over the
paper protocol (``sets="protocol"``: learning sets with exploration, then the test sets greedily
with frozen tables) and seeded like :func:`scenarios.protocol.execute`, it makes the very same
decisions as the built-in ``ql`` allocator, so both report the same test-set completion.

    env = make_parallel_env("paper", sets="protocol")      # scenarios.envs
    result = play_protocol(env, seed=0)                    # learners trained, then tested
    baseline = play_protocol(env, seed=0, learn=False)     # untrained: bids on everything
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from learning.learner import Decision, QLearners
from learning.qtable import DO, WAIT
from learning.seeding import run_generators
from sim.scenario import Scenario


class QLTeam:
    """One QL-MRTA learner per robot, acting on PettingZoo observations (agent name -> obs).

    The learners are one :class:`learning.learner.QLearners` (``learner_``), the very class
    the built-in ``ql`` allocator learns with; the team only reads observations and rewards.
    """

    def __init__(self, scenario: Scenario, rng: np.random.Generator) -> None:
        self.scenario = scenario
        self.agents = [r.name for r in scenario.robots]
        self.learner_ = QLearners(scenario.capability_matrix(), scenario.learning)
        self.learner_.reset(rng)
        self.decisions_ = np.zeros(2, dtype=np.int64)  # do, wait (counted in every phase)
        self._round: list[list[tuple[int, int, int]]] = []

    def begin_set(self, learning: bool) -> None:
        """Start a set; epsilon decays once per learning set."""
        self.learner_.begin_set(learning)

    def end_set(self) -> None:
        """Close every open decision as terminal: the set is an episode."""
        self.learner_.end_set()

    def act(self, obs: dict[str, dict]) -> dict[str, np.ndarray]:
        """Bids for this round: high-priority slots always, low ones as the Q-table says."""
        actions, self._round = {}, []
        learner = self.learner_
        for j, agent in enumerate(self.agents):
            o = obs[agent]
            action = np.zeros(len(o["task_valid"]), dtype=np.int8)
            decided = []
            for t in np.flatnonzero(o["task_valid"]):
                learner.push(j, int(o["task_type"][t]))
                if not o["free"]:
                    continue
                if not o["task_high"][t]:
                    s, a = learner.decide(j)
                    self.decisions_[a] += 1
                    decided.append((s, a, int(t)))
                    if a == WAIT:
                        continue
                action[t] = 1
            actions[agent] = action
            self._round.append(decided)
        return actions

    def observe(self, rewards: dict[str, float], infos: dict[str, dict]) -> None:
        """Learn from one step: open this round's decisions (the won one last), credit rewards."""
        learner = self.learner_
        if not learner.learning_:
            return
        for j, agent in enumerate(self.agents):
            won = infos[agent]["won"]
            for s, a, _slot in sorted(self._round[j], key=lambda d: d[2] == won):
                learner.open(j, Decision(s, a), next_state=s)
            learner.credit(j, rewards[agent])


@dataclass
class ProtocolResult:
    """Test-set outcome of one :func:`play_protocol` run."""

    announced: dict[str, int]  # low, high
    allocated: dict[str, int]
    completion: dict[str, float]  # low, high, all
    test_decisions: dict[str, int] = field(default_factory=dict)  # do / wait on test sets
    q_nonzero: int = 0  # Q entries the learners changed from 0


def play_protocol(env, seed: int, learn: bool = True) -> ProtocolResult:
    """Train QL-MRTA learners on the learning sets, then play the test sets greedily.

    Args:
        env: an :class:`learning.pz_env.AllocationParallelEnv` built with ``sets="protocol"``.
        seed: the run seed: the stream comes from it exactly as in ``scenarios.protocol``, and
            exploration from its third spawned generator, as the built-in ``ql`` allocator's.
        learn: False plays with untrained tables: ties go to ``do``, so every robot bids on every
            task it can do (the market baseline).

    Returns:
        Test-set counts and completion, the learners' test decisions and changed Q entries.
    """
    if env.sets != "protocol":
        raise ValueError(f"play_protocol needs an env built with sets='protocol', not {env.sets!r}")
    sc = env.scenario
    n_learn = sc.stream.learn_sets
    team = QLTeam(sc, run_generators(seed).allocator)
    obs, infos = env.reset(seed=seed)
    position, at_test, test_start = -1, None, None
    while env.agents:
        info = infos[env.agents[0]]
        if info["set_position"] != position:
            if position >= 0:
                team.end_set()
            position = info["set_position"]
            team.begin_set(learning=learn and position < n_learn)
            if position == n_learn:
                test_start, at_test = info, team.decisions_.copy()
        actions = team.act(obs)
        obs, rewards, _, _, infos = env.step(actions)
        team.observe(rewards, infos)
    team.end_set()
    final = next(iter(infos.values()))
    announced = {p: final["announced"][p] - test_start["announced"][p] for p in ("low", "high")}
    allocated = {p: final["allocated"][p] - test_start["allocated"][p] for p in ("low", "high")}
    completion = {p: allocated[p] / announced[p] for p in ("low", "high")}
    completion["all"] = sum(allocated.values()) / sum(announced.values())
    test = team.decisions_ - at_test
    return ProtocolResult(
        announced,
        allocated,
        completion,
        {"do": int(test[DO]), "wait": int(test[WAIT])},
        int(sum(np.count_nonzero(t.q_) for t in team.learner_.tables_)),
    )
