"""A Gymnasium loop with hand-written policies, and one rendered frame.

What it shows
    ``gymnasium.make("mrta/Allocation-v0", ...)`` (the id is registered by ``import learning``)
    is the allocation loop as a single-agent environment: one step is one announcement round.
    The observation holds every robot's state (``free``, ``busy_s``, ``experience``) and the
    announced batch padded to 7 slots (``task_type``, ``task_high``, ``task_valid``); the action
    is an (m robots, 7 slots) 0/1 matrix: bid or wait. The market's priority auction resolves
    the bids with the robots' costs; the reward is the team reward of QL-MRTA.

    Three policies play one episode each on the same seed (so the same task stream):

    - ``always_bid``: every free robot bids for every task it can do (this is the market);
    - ``keep_reserve``: free robots always bid for high-priority tasks, but for low-priority
      ones only while more than ``RESERVE`` robots are free;
    - ``random_bids``: a coin per robot and slot, from a seeded ``numpy.random.Generator``.

    The observation does not say which robot can do which type; the policies read it from the
    scenario (``Scenario.capability_matrix()``; ``env.unwrapped.capable`` holds the same).
    The scenario is loaded and shortened in Python (``scenarios.protocol.apply_overrides``) and
    the ``Scenario`` object is passed to ``gymnasium.make``; a name (``scenario="paper"``) works
    too.

    With ``render_mode="rgb_array"``, ``env.render()`` returns an (H, W, 3) uint8 frame: a
    status board in the abstract world (robots' remaining work and the batch), the arena as in
    ``mrta render`` in a spatial one (``--scenario paper_spatial --cost distance``).

Outputs (in the current folder, or ``--out``)
    ``gym_episode.csv``  one row per policy: steps, return, completion (low, high, all);
    ``gym_frame.png``    the frame ``env.render()`` gave at step ``--frame-step``.

Run
    cd "$(mktemp -d)" && python /path/to/examples/03_gymnasium_loop.py
        the whole ``paper`` stream (45 sets x 18 rounds = 810 steps per episode): a few seconds;
    ... --quick                 3 sets;
    ... --scenario paper_spatial --cost distance --sets 3
                                the pymunk world (about 1 s per set and policy).
"""

from __future__ import annotations

import argparse
import csv
from collections.abc import Callable
from pathlib import Path

import gymnasium
import numpy as np

import learning  # noqa: F401  (importing it registers "mrta/Allocation-v0")
from scenarios.loader import load_scenario
from scenarios.protocol import apply_overrides

ENV_ID = "mrta/Allocation-v0"
RESERVE = 2  # keep_reserve: robots kept free for high-priority tasks

Policy = Callable[[dict, np.ndarray, np.random.Generator], np.ndarray]


def can_bid(obs: dict, capable: np.ndarray) -> np.ndarray:
    """(m, 7) bool: robot is free, slot holds a task, and the robot can do its type."""
    valid = obs["task_valid"].astype(bool)
    free = obs["free"].astype(bool)
    return capable[:, obs["task_type"]] & valid[None, :] & free[:, None]


def always_bid(obs: dict, capable: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return can_bid(obs, capable).astype(np.int8)


def keep_reserve(obs: dict, capable: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    bid = can_bid(obs, capable)
    if obs["free"].sum() <= RESERVE:
        bid[:, ~obs["task_high"].astype(bool)] = False
    return bid.astype(np.int8)


def random_bids(obs: dict, capable: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    bid = can_bid(obs, capable)
    return (bid & (rng.random(bid.shape) < 0.5)).astype(np.int8)


POLICIES: dict[str, Policy] = {
    "always_bid": always_bid,
    "keep_reserve": keep_reserve,
    "random_bids": random_bids,
}


def play(env, policy: Policy, capable, seed: int, frame_step: int | None):
    """One episode; returns (row of results, frame or None)."""
    rng = np.random.default_rng(seed)  # the policy's own generator
    obs, info = env.reset(seed=seed)
    total, steps, frame = 0.0, 0, None
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs, capable, rng))
        total += reward
        steps += 1
        done = terminated or truncated
        if steps == frame_step:
            frame = env.render()
    announced = info["announced"]["low"] + info["announced"]["high"]
    allocated = info["allocated"]["low"] + info["allocated"]["high"]
    row = {
        "steps": steps,
        "return": total,
        "completion_low": info["completion"]["low"],
        "completion_high": info["completion"]["high"],
        "completion_all": allocated / announced,
    }
    return row, frame


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 task sets")
    parser.add_argument("--scenario", default="paper", help="bundled name or TOML path")
    parser.add_argument("--cost", default="abstract", help="abstract, distance or time")
    parser.add_argument("--sets", type=int, default=None, help="play only the first N sets")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--frame-step", type=int, default=20, help="render after this step")
    parser.add_argument("--out", type=Path, default=Path("."), help="output folder")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    scenario = load_scenario(args.scenario)
    sets = 3 if args.quick and args.sets is None else args.sets
    if sets is not None:
        sets = min(sets, scenario.stream.n_sets)
        overrides = (("stream.n_sets", sets), ("stream.learn_sets", sets))
        scenario = apply_overrides(scenario, (*overrides, ("stream.test_sets", sets)))
    capable = scenario.capability_matrix()

    rows, frame = [], None
    for i, (name, policy) in enumerate(POLICIES.items()):
        env = gymnasium.make(
            ENV_ID,
            scenario=scenario,
            cost=args.cost,
            render_mode="rgb_array" if i == 0 else None,  # one frame is enough
        )
        row, got = play(env, policy, capable, args.seed, args.frame_step if i == 0 else None)
        env.close()
        frame = got if got is not None else frame
        rows.append({"policy": name, **row})

    path = args.out / "gym_episode.csv"
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"{scenario.name}, cost {args.cost}, seed {args.seed}: one episode per policy")
    print(f"{'policy':<13} {'steps':>6} {'return':>9} {'low':>6} {'high':>6} {'all':>6}")
    for r in rows:
        print(
            f"{r['policy']:<13} {r['steps']:>6} {r['return']:>9.1f} {r['completion_low']:>6.3f}"
            f" {r['completion_high']:>6.3f} {r['completion_all']:>6.3f}"
        )
    print(f"wrote {path}")
    if frame is not None:
        from PIL import Image

        frame_path = args.out / "gym_frame.png"
        Image.fromarray(frame).save(frame_path)
        print(f"wrote {frame_path} ({frame.shape[1]}x{frame.shape[0]} px, step {args.frame_step})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
