"""The PettingZoo env: API conformance, seeding, agreement with the Gymnasium env and the
built-in allocators, per-agent rewards, and QL-MRTA trained through it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

pytest.importorskip("pettingzoo")
from pettingzoo.test import parallel_api_test, parallel_seed_test

from learning.gym_env import AllocationEnv, market_policy
from learning.pz_env import AllocationParallelEnv, always_bid
from learning.pz_train import play_protocol
from scenarios.envs import make_parallel_env
from scenarios.loader import bundled_names
from scenarios.protocol import RunSpec, execute


def test_parallel_api_test_passes(small_paper):
    parallel_api_test(AllocationParallelEnv(small_paper), num_cycles=1000)


def test_parallel_seed_test_passes(small_paper):
    parallel_seed_test(lambda: AllocationParallelEnv(small_paper))


def random_rollout(env, seed, policy_seed):
    rng = np.random.default_rng(policy_seed)
    obs, infos = env.reset(seed=seed)
    trace = []
    while env.agents:
        actions = {a: rng.integers(0, 2, 7) for a in env.agents}
        obs, rew, _, _, infos = env.step(actions)
        trace.append(
            (
                {a: {k: v.tolist() for k, v in o.items() if k != "free"} for a, o in obs.items()},
                rew,
                infos,
            )
        )
    return trace


def test_same_seed_same_trajectory_other_seed_another(small_paper):
    a = random_rollout(AllocationParallelEnv(small_paper), 3, 0)
    b = random_rollout(AllocationParallelEnv(small_paper), 3, 0)
    c = random_rollout(AllocationParallelEnv(small_paper), 4, 0)
    assert a == b
    assert a != c
    assert all(set(step[1]) == {r.name for r in small_paper.robots} for step in a)


def test_observations_fit_their_spaces_and_say_what_the_agent_can_do(paper):
    env = make_parallel_env("paper")
    obs, _ = env.reset(seed=0)
    cap = paper.capability_matrix()
    for _ in range(30):
        for j, agent in enumerate(env.agents):
            o = obs[agent]
            assert env.observation_space(agent).contains(o)
            assert not o["position"].any()  # abstract world: zeros
            valid = o["task_valid"].astype(bool)
            k = len(env.batch_)
            assert not valid[k:].any()
            assert np.array_equal(valid[:k], cap[j, env.batch_.types])
            assert np.array_equal(o["task_high"][:k].astype(bool), env.batch_.high & valid[:k])
        obs, *_ = env.step(always_bid(obs))


@pytest.mark.skipif("paper_spatial" not in bundled_names(), reason="no paper_spatial scenario")
def test_spatial_positions_come_from_the_world_snapshot():
    env = make_parallel_env("paper_spatial", cost="distance")
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        obs, *_ = env.step(always_bid(obs))
    positions = env.world.snapshot().positions
    for j, agent in enumerate(env.agents):
        assert env.observation_space(agent).contains(obs[agent])
        assert np.allclose(obs[agent]["position"], positions[j], atol=1e-4)


def test_always_bid_equals_gymnasium_market_policy(paper):
    seed = 5
    pz = AllocationParallelEnv(paper)
    obs, infos = pz.reset(seed=seed)
    while pz.agents:
        obs, _, _, _, infos = pz.step(always_bid(obs))
    gym_env = AllocationEnv(paper)
    gobs, ginfo = gym_env.reset(seed=seed)
    done = False
    while not done:
        gobs, _, done, _, ginfo = gym_env.step(market_policy(gym_env, gobs))
    info = infos["R1"]
    assert info["announced"] == ginfo["announced"]
    assert info["allocated"] == ginfo["allocated"]
    assert 0.3 < info["completion"]["low"] < info["completion"]["high"] < 1.0


def test_rewards_are_the_qlmrta_rewards_per_robot(paper):
    """Recompute every agent's reward from what it saw: wins, and penalties while busy-low."""
    p = paper.learning
    env = AllocationParallelEnv(paper)
    obs, _ = env.reset(seed=2)
    job_high = dict.fromkeys(env.agents, False)
    penalties = 0
    while env.agents:
        before = obs
        obs, rew, _, _, infos = env.step(always_bid(obs))
        assignment = env.last_assignment_
        for agent, o in before.items():
            won = infos[agent]["won"]
            expect = 0.0
            if won >= 0:
                expect += p.reward_high if o["task_high"][won] else p.reward_low
            elif not o["free"] and not job_high[agent]:
                k = assignment.size
                lost_high = o["task_valid"][:k].astype(bool) & o["task_high"][:k].astype(bool)
                n_lost = int((lost_high & (assignment < 0)).sum())
                expect -= p.penalty_lost_high * n_lost
                penalties += n_lost
            assert rew[agent] == expect, (agent, rew[agent], expect)
            if won >= 0:
                job_high[agent] = bool(o["task_high"][won])
    assert penalties > 0


@pytest.fixture(scope="module")
def protocol_env():
    return make_parallel_env("paper", sets="protocol")


@pytest.mark.parametrize("seed", [0, 1])
def test_trained_through_pettingzoo_equals_builtin_allocators(protocol_env, seed):
    trained = play_protocol(protocol_env, seed)
    ql = execute(RunSpec("paper", "ql", seed=seed))
    assert trained.completion == ql["completion"]["overall"]
    assert sum(trained.allocated.values()) == ql["tasks"]["allocated"]
    untrained = play_protocol(protocol_env, seed, learn=False)
    market = execute(RunSpec("paper", "market", seed=seed))
    assert untrained.completion == market["completion"]["overall"]


@pytest.mark.slow
def test_training_raises_high_priority_completion_over_always_bid(protocol_env):
    seeds = range(5)
    trained = [play_protocol(protocol_env, s) for s in seeds]
    untrained = [play_protocol(protocol_env, s, learn=False) for s in seeds]
    pairs = list(zip(trained, untrained, strict=True))
    high_gain = [t.completion["high"] - u.completion["high"] for t, u in pairs]
    low_gain = [t.completion["low"] - u.completion["low"] for t, u in pairs]
    assert np.mean(high_gain) > 0.015  # paper §7: high priority up ...
    assert stats.ttest_1samp(high_gain, 0.0, alternative="greater").pvalue < 0.01
    assert np.mean(low_gain) < 0  # ... low priority down a little
    for t, u in pairs:
        assert t.q_nonzero > 500  # the Q-tables learned something
        assert t.test_decisions["wait"] > 0.1 * t.test_decisions["do"]  # and wait on low tasks
        assert u.test_decisions["wait"] == 0 and u.q_nonzero == 0
