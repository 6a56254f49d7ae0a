"""The PettingZoo parallel env: every robot is an agent with its own observation and reward.

What it shows
    ``scenarios.envs.make_parallel_env("paper")`` is the allocation loop as a multi-agent
    game (PettingZoo ``ParallelEnv``): one step is one announcement round, the agents are the
    robots (named as in the scenario), and each agent sees only itself (``free``, ``busy_s``,
    ``experience``, ``position`` in spatial worlds) and the batch padded to 7 slots, where
    ``task_valid`` is 1 only for the tasks *it* can do. Its action is 7 bits: bid or wait per
    slot; the market's priority auction resolves the bids; each agent gets the QL-MRTA reward
    of its own robot. Each agent's info says which slot it won (``won``, -1 if none) and holds
    the team counts.

    Two decentralised policies play one episode each on the same seed (same task stream):

    - ``always_bid``: every free agent bids for every task it can do (the market);
    - ``shy``: an agent bids for low-priority tasks only with probability ``P_LOW``, drawn
      from its own seeded ``numpy.random.Generator`` (one per agent).

    PettingZoo is an optional extra (``pip install 'expt-mrta[marl]'``): without it the script
    says so and exits with code 0. ``learning.pz_train`` trains QL-MRTA learners through this
    env (one tabular learner per agent).

Outputs (in the current folder, or ``--out``)
    ``pettingzoo_team.csv``    one row per policy: steps, team return, completion;
    ``pettingzoo_agents.csv``  one row per policy and agent: return and tasks won.

Run
    cd "$(mktemp -d)" && python /path/to/examples/05_pettingzoo.py
        the whole ``paper`` stream (45 sets, 810 rounds): a few seconds;
    ... --quick        3 sets;
    ... --scenario paper_spatial --cost distance --sets 3   the pymunk world.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from scenarios.loader import load_scenario
from scenarios.protocol import apply_overrides

P_LOW = 0.5  # shy: probability of bidding for a low-priority task


def always_bid(obs: dict, rngs: dict) -> dict:
    return {a: (o["task_valid"] * o["free"]).astype(np.int8) for a, o in obs.items()}


def shy(obs: dict, rngs: dict) -> dict:
    actions = {}
    for agent, o in obs.items():
        valid = o["task_valid"].astype(bool) & bool(o["free"])
        low = ~o["task_high"].astype(bool)
        skip = low & (rngs[agent].random(valid.shape) >= P_LOW)
        actions[agent] = (valid & ~skip).astype(np.int8)
    return actions


POLICIES = {"always_bid": always_bid, "shy": shy}


def play(env, policy, seed: int) -> tuple[dict, dict]:
    """One episode; returns (team row, agent -> {return, won})."""
    streams = np.random.SeedSequence(seed).spawn(len(env.possible_agents))
    rngs = {a: np.random.default_rng(s) for a, s in zip(env.possible_agents, streams, strict=True)}
    per_agent = {a: {"return": 0.0, "won": 0} for a in env.possible_agents}
    obs, infos = env.reset(seed=seed)
    steps = 0
    while env.agents:
        obs, rewards, _terminations, _truncations, infos = env.step(policy(obs, rngs))
        steps += 1
        for agent, r in rewards.items():
            per_agent[agent]["return"] += r
            per_agent[agent]["won"] += int(infos[agent]["won"] >= 0)
    team = next(iter(infos.values()))  # every agent's info carries the team counts
    announced = team["announced"]["low"] + team["announced"]["high"]
    allocated = team["allocated"]["low"] + team["allocated"]["high"]
    row = {
        "steps": steps,
        "team_return": sum(v["return"] for v in per_agent.values()),
        "completion_low": team["completion"]["low"],
        "completion_high": team["completion"]["high"],
        "completion_all": allocated / announced,
    }
    return row, per_agent


def write_csv(path: Path, rows: list[dict]) -> None:
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 task sets")
    parser.add_argument("--scenario", default="paper", help="bundled name or TOML path")
    parser.add_argument("--cost", default="abstract", help="abstract, distance or time")
    parser.add_argument("--sets", type=int, default=None, help="play only the first N sets")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("."), help="output folder")
    args = parser.parse_args(argv)

    from scenarios.envs import make_parallel_env

    scenario = load_scenario(args.scenario)
    sets = 3 if args.quick and args.sets is None else args.sets
    if sets is not None:
        sets = min(sets, scenario.stream.n_sets)
        keys = ("stream.n_sets", "stream.learn_sets", "stream.test_sets")
        scenario = apply_overrides(scenario, [(k, sets) for k in keys])
    try:
        env = make_parallel_env(scenario, cost=args.cost)
    except ImportError as exc:  # pettingzoo is the optional extra "marl"
        print(f"skipped: {exc}")
        return 0
    args.out.mkdir(parents=True, exist_ok=True)

    team_rows, agent_rows = [], []
    for name, policy in POLICIES.items():
        row, per_agent = play(env, policy, args.seed)
        team_rows.append({"policy": name, **row})
        agent_rows += [{"policy": name, "agent": a, **v} for a, v in per_agent.items()]
    env.close()
    write_csv(args.out / "pettingzoo_team.csv", team_rows)
    write_csv(args.out / "pettingzoo_agents.csv", agent_rows)

    agents = env.possible_agents
    print(f"{scenario.name}, cost {args.cost}, seed {args.seed}: return per agent")
    print(f"{'policy':<11} " + " ".join(f"{a:>6}" for a in agents) + f" {'team':>7} {'all':>6}")
    for team in team_rows:
        mine = {r["agent"]: r["return"] for r in agent_rows if r["policy"] == team["policy"]}
        print(
            f"{team['policy']:<11} "
            + " ".join(f"{mine[a]:>6.0f}" for a in agents)
            + f" {team['team_return']:>7.0f} {team['completion_all']:>6.3f}"
        )
    print(f"wrote {args.out / 'pettingzoo_team.csv'}, {args.out / 'pettingzoo_agents.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
