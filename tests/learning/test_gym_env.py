"""The Gymnasium environment: registration, check_env, seeding, and agreement with the loop."""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import learning  # noqa: F401  (registers mrta/Allocation-v0)
from allocation.auction import MarketAllocator
from allocation.costs import make_cost_model
from learning.episode import run_protocol
from learning.gym_env import MAX_SLOTS, market_policy
from sim.tasks import generate_stream
from sim.world import AbstractWorld


@pytest.fixture()
def env():
    e = gymnasium.make("mrta/Allocation-v0", scenario="paper")
    yield e
    e.close()


def test_check_env_passes(env):
    check_env(env.unwrapped, skip_render_check=True)


def test_spaces(env, paper):
    assert env.action_space.shape == (paper.n_robots, MAX_SLOTS)
    obs, _ = env.reset(seed=0)
    assert obs["experience"].shape == (paper.n_robots, paper.n_types)
    k = int(obs["task_valid"].sum())
    assert 3 <= k <= 7 and obs["task_valid"][:k].all() and not obs["task_valid"][k:].any()


def rollout(env, seed, policy):
    obs, info = env.reset(seed=seed)
    rewards, done = [], False
    while not done:
        obs, r, term, trunc, info = env.step(policy(env.unwrapped, obs))
        rewards.append(r)
        done = term or trunc
    return rewards, info


def test_reset_seed_is_deterministic(env):
    def random_policy(e, obs):
        return e.unwrapped.np_random.integers(0, 2, size=e.action_space.shape, dtype=np.int8)

    a = rollout(env, 11, random_policy)
    b = rollout(env, 11, random_policy)
    c = rollout(env, 12, random_policy)
    assert a == b
    assert a[0] != c[0]


def test_market_policy_equals_builtin_loop(env, paper):
    seed = 5
    _, info = rollout(env, seed, market_policy)
    ss = np.random.SeedSequence(seed).spawn(3)
    stream = generate_stream(paper, np.random.default_rng(ss[0]))
    alloc = MarketAllocator(paper)
    rec = run_protocol(
        paper,
        stream,
        alloc,
        AbstractWorld(paper),
        make_cost_model("abstract", paper),
        np.random.default_rng(ss[1]),
        phases=(("test", list(range(paper.stream.n_sets))),),
    )
    ids, assigned = rec.test.arrays()
    high = stream.high[ids]
    assert info["announced"] == {"low": int((~high).sum()), "high": int(high.sum())}
    assert info["allocated"] == {
        "low": int(((assigned >= 0) & ~high).sum()),
        "high": int(((assigned >= 0) & high).sum()),
    }
    assert 0.3 < info["completion"]["low"] < info["completion"]["high"] < 1.0


def test_reward_follows_spec(env, paper):
    """A round where everything is taken pays reward_high per high and reward_low per low."""
    obs, _ = env.reset(seed=1)
    _, reward, *_ = env.step(market_policy(env.unwrapped, obs))
    info = env.unwrapped.rounds.info()
    p = paper.learning
    assert (
        reward
        == p.reward_high * info["allocated"]["high"] + p.reward_low * info["allocated"]["low"]
    )


def test_rgb_array_abstract_status_board():
    env = gymnasium.make("mrta/Allocation-v0", scenario="paper", render_mode="rgb_array")
    obs, _ = env.reset(seed=0)
    first = env.render()
    env.step(market_policy(env.unwrapped, obs))
    second = env.render()
    assert first.shape == (600, 600, 3) and first.dtype == np.uint8
    assert not np.array_equal(first, second)  # robots became busy


def test_rgb_array_spatial_is_the_gif_frame():
    from sim.render import render_frame

    env = gymnasium.make(
        "mrta/Allocation-v0", scenario="paper_spatial", cost="distance", render_mode="rgb_array"
    )
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        obs, *_ = env.step(market_policy(env.unwrapped, obs))
    frame = env.render()
    traj = env.unwrapped.recorder_.finish()
    assert traj.task_id.size > 0 and (traj.task_robot >= 0).any()
    assert np.array_equal(frame, render_frame(traj, float(traj.times_s[-1])))
    assert frame.shape == (600, 600, 3)
