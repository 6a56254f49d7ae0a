"""``mrta bench``: speed and memory, reported as ratios against baselines measured in the same run.

- ``sim``: the full spatial loop in the units users pay: the real-time factor, wall seconds per
  simulated robot-hour, the price of avoidance (wall time per simulated second with ORCA and
  the traffic rules, the defaults, over without avoidance, and with ORCA alone, the rules off,
  over without: all measured in this process) and the loop's time per physics step in steps of a
  calibration space (``scenarios.bench.calibration``: the same contact-free space of as many robots
  in every run; the world's bare ``space.step`` on the same bodies is reported too, but its cost
  moves with the contacts). With 10 robots it is the paper scenario itself (``paper_spatial``,
  market auction, distance bids): the task stream, bidding, allocation, physics, control, task
  bookkeeping and trajectory recording of ``mrta run``, timed over the first ``PAPER_SETS`` task
  sets (learning and test phase). Beside it, and for 100 and 1000 robots, a synthetic arena in which
  every robot is always busy (``sim.bench_sim``: every 10 simulated seconds the free robots' tasks
  are auctioned, bids being planned path lengths (:class:`PlannedMarket`, the ``distance`` cost
  model); physics, control, task bookkeeping and recording as in a run); the 10-robot figures of
  that arena are reported as ``busy_*`` members of the ``"10"`` row. ``bids_ms`` is the time the
  ``distance`` cost model takes to bid every robot on a paper-sized batch of 7 tasks,
  ``round_bids_ms`` / ``round_auction_ms`` what bidding and the auction took per round of the timed
  loop. With 1000 robots the bids come from the distance field
  (``sim.spatial.navigation.distfield``), built during the warm-up: its build time, memory, ms per
  call for all robots x all 500 sites and x 50 sites against numpy straight lines, and its largest
  difference from the exact query are reported (``sim.bench_sim.field_report``);
- ``gif``: a 200-frame 600x600 GIF of the 10-robot ``paper_spatial`` scenario (one task set,
  ExpT-MRTA, distance cost, seed 0) with our renderer against ``FuncAnimation`` +
  ``PillowWriter`` on the same frames (``sim.bench_render``);
- ``alloc``: allocation time per round against team size, 50 task types, 7 tasks a round
  (``allocation.bench_alloc``), market plus QL-MRTA and ExpT-MRTA; the market's ms per round
  under the abstract, straight-line, planned-distance and planned-time cost models at 10, 100
  and 1000 robots in the synthetic arena (``bench_costs``); and scipy's linear assignment
  against LAPJV (``lapx``, when installed) on the spatial rounds' matrices at 100 to 2000
  bidders (``bench_assignment``).

Machines here are shared and noisy: compare the ratios, not the absolute times. The ``sim``
part's three loops of an arena run side by side in turns of a few tens of milliseconds
(``scenarios.bench.relay``), so a slow spell falls on all three alike; ``--repeat N`` runs them
N times, keeps each loop's quickest round and reports the price of every round beside it.
"""

from __future__ import annotations

import sys

PARTS = ("sim", "gif", "alloc", "maps")
PRICE_LABELS = {
    "control": "control period",
    "traffic": "traffic rules",
    "jams": "look-ahead and jam rules",
    "sites": "site work",
    "physics": "physics steps",
    "rest": "the rest",
}
PAPER_SETS = 8  # task sets of paper_spatial timed by the 10-robot figure (about 3,400 s simulated)
SIM_SIZES = (10, 100, 1000)  # robots in the sim part's busy synthetic arenas
PAPER_ROBOTS = 10  # paper_spatial's team (the calibration space beside its loops)


class PlannedMarket:
    """``allocate(batch)`` for ``sim.bench_sim``: the market auction among the free robots,
    each bidding its planned path length (the ``distance`` cost model: ``GridPlanner.distances``,
    from the distance field with hundreds of robots). ``timings_`` adds up the seconds spent
    bidding and in the auction, and the rounds."""

    def __init__(self, scenario, world) -> None:
        from allocation.costs import DistanceCost

        self.world = world
        self.cost = DistanceCost(scenario, world.planner)
        self.timings_ = {"bids_s": 0.0, "auction_s": 0.0, "rounds": 0}

    def __call__(self, batch):
        import time

        import numpy as np

        from allocation.auction import solve_priority_assignment

        state = self.world.snapshot()
        free = np.flatnonzero(state.free)
        t0 = time.perf_counter()
        costs = self.cost.costs(state, batch)
        t1 = time.perf_counter()
        won = solve_priority_assignment(costs[free], batch.high)  # only free robots bid
        t2 = time.perf_counter()
        self.timings_["bids_s"] += t1 - t0
        self.timings_["auction_s"] += t2 - t1
        self.timings_["rounds"] += 1
        return np.where(won >= 0, free[np.maximum(won, 0)], -1), costs


def bench_paper_loop(
    sets: int = PAPER_SETS,
    seed: int = 0,
    avoidance: str = "none",
    traffic: str = "on",
    timed: bool = True,
    clock=None,
) -> dict[str, float]:
    """The 10-robot paper scenario through the whole loop of ``mrta run`` (with
    ``[spatial] avoidance`` set to ``avoidance`` and ``[spatial.traffic] rules`` to
    ``traffic``), against bare ``space.step`` on the same bodies afterwards; with ``timed``
    the parts of the loop are timed too (``scenarios.bench.loop.loop_timers``). ``clock``:
    the loop's wall clock (``time.perf_counter`` if None; ``Relay.clock`` when loops take
    turns, ``scenarios.bench.relay``).

    Returns:
        ``{"steps_per_s", "rtf", "s_per_robot_h", "calib_ratio", "calib_step_us",
        "bare_ratio", "bare_steps_per_s", "sim_s", "wall_s", "avoid_share",
        "avoid_bare_ratio", "sites_share", "sites_bare_ratio", "control_share",
        "control_calib_ratio", "physics_calib_ratio", "parts_s"}`` (as
        :func:`scenarios.bench.loop.bench_sim` says; untimed, without the timers' keys).
    """
    import time

    from learning.episode import run_protocol
    from scenarios.bench.calibration import calibration_step_s
    from scenarios.bench.loop import bare_step_time, loop_timers, timer_figures
    from scenarios.protocol import RunSpec, build_run
    from sim.recording import TrajectoryRecorder

    part = (("stream.n_sets", sets), ("stream.learn_sets", sets), ("stream.test_sets", sets))
    part += (("spatial.avoidance", avoidance), ("spatial.traffic.rules", traffic))
    spec = RunSpec("paper_spatial", "market", "distance", seed, part)
    scenario, stream, world, cost, allocator, rng = build_run(spec)
    recorder = TrajectoryRecorder.for_scenario(scenario)
    world.recorder = recorder
    clock = time.perf_counter if clock is None else clock
    steps0 = world.steps_
    t0 = clock()
    with loop_timers(type(world.control), timed) as timers:
        run_protocol(scenario, stream, allocator, world, cost, rng, trace=False, recorder=recorder)
    wall = clock() - t0
    steps = world.steps_ - steps0
    bare = bare_step_time(world, max(60, steps // 4))
    n = scenario.n_robots
    calib = calibration_step_s(n, 600)
    return {
        "steps_per_s": steps / wall,
        "rtf": steps * world.dt_s / wall,
        "s_per_robot_h": wall / (n * steps * world.dt_s / 3600.0),
        "calib_ratio": (wall / steps) / calib,
        "calib_step_us": 1e6 * calib,
        "bare_ratio": (wall / steps) / bare,
        "bare_steps_per_s": 1.0 / bare,
        "sim_s": steps * world.dt_s,
        "wall_s": wall,
        **timer_figures(timers, wall, steps, bare, calib),
    }


def _paper_trajectory():
    from scenarios.protocol import RunSpec, execute, load_named
    from sim.recording import TrajectoryRecorder

    sc = load_named("paper_spatial")
    recorder = TrajectoryRecorder.for_scenario(sc)
    one_set = (("stream.n_sets", 1), ("stream.learn_sets", 1), ("stream.test_sets", 1))
    execute(RunSpec("paper_spatial", "expt", "distance", 0, one_set), recorder=recorder)
    return recorder.finish()


def bench_maps_part(say) -> dict:
    """The ``maps`` part: preparing a 30 m x 50 m synthetic warehouse map at 3 cm
    (``sim.maps.probe``: reading it, and its cells turned into convex polygons) and building
    the planner over those polygons, in a temporary folder."""
    import tempfile
    import time

    from sim.maps.probe import prepare_time_probe
    from sim.scenario import SpatialSpec
    from sim.spatial.navigation.planning import GridPlanner

    say("maps: a 30 m x 50 m warehouse map at 3 cm, read, traced into polygons, planned over ...")
    with tempfile.TemporaryDirectory() as folder:
        out = prepare_time_probe(folder, geometry=True)
    geometry = out.pop("geometry")
    spec = SpatialSpec(
        width_m=geometry.width_m, height_m=geometry.height_m, obstacles=geometry.arena_polygons
    )
    t0 = time.perf_counter()
    GridPlanner(spec)
    out["planner_s"] = time.perf_counter() - t0
    say(
        f"  {out['cells']:,} cells: read {out['load_s']:.2f} s, polygons {out['geometry_s']:.2f} s "
        f"({out['polygons']} polygons, {out['vertices']} vertices, {out['specks_dropped']} specks "
        f"dropped), planner {out['planner_s']:.2f} s"
    )
    say("maps: distance bids of the depot's 10 robots for 7 tasks, compiled vs numpy test ...")
    out["depot_bids"] = bench_map_bids()
    b = out["depot_bids"]
    say(
        f"  planner {b['planner_s']:.2f} s; a 10 x 7 bid at the depot's sites "
        f"{b['known_ms']:.1f} ms (numpy {b['known_ref_ms']:.1f} ms), at 7 new points "
        f"{b['new_ms']:.1f} ms (numpy {b['new_ref_ms']:.1f} ms)"
    )
    return out


def bench_map_bids(rounds: int = 20, seed: int = 0) -> dict:
    """Wall time of the distance bids on the bundled ``depot`` map: 10 robots at their starts
    for 7 tasks, at the scenario's sites (their geodesic fields kept from round to round, as in
    a run) and at 7 new free points each round (a field built per point); the median over
    ``rounds``, with the planner's compiled visibility test and with its numpy reference."""
    import copy
    import time

    import numpy as np

    from scenarios.loader import load_scenario
    from sim.spatial.navigation.planning import GridPlanner

    sc = load_scenario("depot")
    t0 = time.perf_counter()
    planner = GridPlanner(sc.spatial)
    out = {"planner_s": time.perf_counter() - t0}
    rng = np.random.default_rng(seed)
    pos = np.array([r.start_xy for r in sc.robots], dtype=float)
    sites = np.array([p for pts in sc.spatial.sites for p in pts], dtype=float)
    known = [sites[rng.choice(len(sites), 7, replace=False)] for _ in range(rounds)]
    size = np.array([sc.spatial.width_m, sc.spatial.height_m])
    free: list[np.ndarray] = []
    while sum(map(len, free)) < rounds * 7:  # a few hundred at a time: free() is (n, P, E)
        draw = rng.uniform(0.0, size, (200, 2))
        free.append(draw[planner.free(draw)])
    points = np.concatenate(free)[: rounds * 7].reshape(rounds, 7, 2)
    for name in ("", "_ref"):
        for kind, batches in (("known", known), ("new", points)):
            fresh = copy.copy(planner)  # the same arena with no goal fields yet
            fresh._fields = {}
            if name:
                fresh.blocked = fresh.blocked_reference
            times = []
            for batch in batches:
                t0 = time.perf_counter()
                fresh.distances(pos, batch)
                times.append(time.perf_counter() - t0)
            out[f"{kind}{name}_ms"] = 1e3 * float(np.median(times))
    return out


def run_bench(parts=PARTS, progress: bool = True, repeat: int = 1, split: bool = False) -> dict:
    """Run the chosen parts; print a readable table when ``progress`` is on. ``repeat``: rounds
    of the ``sim`` part, ``split``: one timed round more to split its price
    (:func:`bench_sim_part`)."""
    out: dict = {}

    def say(text: str) -> None:
        if progress:
            print(text, file=sys.stdout, flush=True)

    if "sim" in parts:
        out.update(bench_sim_part(say, repeat, split))
    if "gif" in parts:
        from scenarios.bench.gif import bench_gif

        say("gif: 200 frames 600x600, paper_spatial, ours vs FuncAnimation + PillowWriter ...")
        out["gif"] = bench_gif(_paper_trajectory(), frames=200, size=(600, 600))
        g = out["gif"]
        say(
            f"  ours {g['seconds']:.2f} s, baseline {g['baseline_seconds']:.2f} s "
            f"({g['baseline_seconds'] / g['seconds']:.1f}x faster)"
        )
    if "maps" in parts:
        out["maps"] = bench_maps_part(say)
    if "alloc" in parts:
        from learning import ALLOCATORS
        from scenarios.bench.alloc import bench_alloc, bench_assignment, bench_costs

        say("alloc: ms per round, 50 types, 7 tasks a round ...")
        out["alloc"] = bench_alloc(allocators=ALLOCATORS)
        for n, r in out["alloc"].items():
            extra = "  ".join(f"{k} {v:.3g}" for k, v in r.items() if k != "ms_per_round")
            say(f"  {n:>5} robots: market {r['ms_per_round']:.3f} ms/round  {extra}")
        say("alloc: market ms per round by cost model, bench arena, robots spread, 7 tasks ...")
        out["alloc_costs"] = bench_costs()
        for n, r in out["alloc_costs"].items():
            field = ""
            if "field_build_s" in r:
                field = (
                    f"  (distance field built once in {r['field_build_s']:.1f} s, holds "
                    f"{r['field_mib']:.0f} MiB, {r['field_peak_mib']:.0f} MiB peak while built)"
                )
            say(
                f"  {n:>5} robots: abstract {r['abstract_ms']:.3f}  straight {r['straight_ms']:.3f}"
                f"  planned distance {r['distance_ms']:.3f}  planned time {r['time_ms']:.3f}{field}"
            )
        say("alloc: linear assignment, scipy vs LAPJV (lapx, if installed), n robots x n tasks ...")
        out["assignment"] = bench_assignment()
        for n, r in out["assignment"].items():
            cells = []
            for kind in ("dense", "sparse"):
                cell = f"{kind}: scipy {r[f'scipy_{kind}_ms']:.1f} ms"
                if f"lapjv_{kind}_ms" in r:
                    same = "same optimum" if r[f"same_{kind}"] else "OTHER OBJECTIVE"
                    cell += (
                        f", LAPJV {r[f'lapjv_{kind}_ms']:.1f} ms "
                        f"(scipy/LAPJV {r[f'ratio_{kind}']:.2f}, {same})"
                    )
                cells.append(cell)
            say(f"  {n:>5} bidders: " + "; ".join(cells))
    return out


CALIB_RATIOS = ("calib_ratio", "control_calib_ratio", "physics_calib_ratio")


def one_yardstick(rows: list[dict], calib_us: float | None = None) -> list[dict]:
    """The loops of one arena (rows of ``bench_sim`` or :func:`bench_paper_loop`) measured
    against one calibration step: ``calib_us``, or if None the quickest of theirs (each loop
    times its own, the best of three short runs, and those differ by more than the loops do on
    a machine whose speed swings). Their figures in calibration steps are rescaled to it, so
    that two loops' ratio of them is their ratio of wall time per step. In place; returns
    ``rows``."""
    calib = min(row["calib_step_us"] for row in rows) if calib_us is None else calib_us
    for row in rows:
        scale = row["calib_step_us"] / calib
        for key in CALIB_RATIOS:
            if key in row:
                row[key] *= scale
        row["calib_step_us"] = calib
    return rows


def bench_sim_part(say, repeat: int = 1, split: bool = False, sizes=SIM_SIZES) -> dict:
    """The ``sim`` part: the loops without avoidance, with ORCA and the traffic rules (the
    defaults), and with ORCA alone (rules off), and what avoidance costs.

    ``repeat`` rounds. In each, the three loops of an arena (the busy arenas of ``sizes``
    robots, then the paper scenario) run side by side in turns of a few tens of
    milliseconds (``scenarios.bench.relay``: one at a time, each timed by its own turns), so
    the swings of a shared machine's speed fall on all three alike, and as users run them:
    no timer inside. Each loop's figures are those of its quickest round (wall time per
    simulated second; interference only ever slows a run down). A price is a ratio of two
    loops of one round: that of the median round (by the price with the rules; of the two
    middle rounds the lower), whose ORCA-alone price is given with it; the busy arena's from
    its own median round. Taken from the loops' quickest rounds, a price would mix rounds.
    ``avoidance_price[n]["price_rounds"]`` keeps the price of each round, whose spread shows
    how far one round can be trusted.

    ``split``: one round more, its loops timed part by part
    (``scenarios.bench.loop.loop_timers``) and run one after the other (the timers replace
    methods of classes the loops share), splits the price into the parts of the control
    period and the physics steps (``avoidance_price[n]["price_parts"]``, with that round's own
    price, ``timed_price``) and gives each loop's control period and physics steps in
    calibration steps. The timers slow the loop with avoidance more than the one without,
    which is why the price is not taken from that round. In every round an arena's three loops
    share one calibration step (:func:`one_yardstick`): in the rounds in turns that of the
    calibration space stepped as a fourth job in turns beside them, as long as they run
    (``scenarios.bench.calibration.calibration_while``), so that it is timed in the same
    mixture of quick and slow spells; in the timed round the quickest of their own."""
    import functools
    import time

    from scenarios.bench.calibration import calibration_while
    from scenarios.bench.loop import TIMED_PARTS, bench_sim
    from scenarios.bench.relay import Relay
    from sim.spatial.world import PymunkWorld

    say("sim: the whole loop, physics at 60 Hz, control at 10 Hz, without and with ORCA ...")
    runs = (("sim", "none", "on"), ("sim_orca", "orca", "on"), ("sim_orca_alone", "orca", "off"))

    def three(loop, timed: bool, robots: int) -> list[dict]:
        """``loop(avoidance, traffic, clock)`` of each run (``robots`` of them): in turns,
        beside the calibration space stepped in turns as long as they run (its step is
        theirs), or timed one by one against the quickest of their own calibration steps
        (:func:`one_yardstick`)."""
        if timed:
            rows = [loop(avoidance, traffic, time.perf_counter) for _, avoidance, traffic in runs]
            return one_yardstick(rows)
        relay = Relay()
        jobs = [
            functools.partial(loop, avoidance, traffic, relay.clock)
            for _, avoidance, traffic in runs
        ]

        def more() -> bool:  # a loop beside the calibration space has not ended
            return relay.running() > 1

        jobs.append(functools.partial(calibration_while, robots, more, relay.tick, relay.clock))
        with relay.ticking(PymunkWorld, "_control"):  # a turn may end after a control period
            *rows, calib_s = relay.run(jobs)
        return one_yardstick(rows, 1e6 * calib_s)

    def one_round(timed: bool) -> dict:
        got: dict[str, dict] = {key: {} for key, _, _ in runs}
        for n in sizes:

            def synthetic(avoidance, traffic, clock, n=n):
                return bench_sim(
                    sizes=(n,),
                    allocator=PlannedMarket,
                    avoidance=avoidance,
                    traffic=traffic,
                    timed=timed,
                    clock=clock,
                )[str(n)]

            for (key, _, _), row in zip(runs, three(synthetic, timed, n), strict=True):
                got[key][str(n)] = row

        def paper(avoidance, traffic, clock):
            return bench_paper_loop(avoidance=avoidance, traffic=traffic, timed=timed, clock=clock)

        for (key, _, _), row in zip(runs, three(paper, timed, PAPER_ROBOTS), strict=True):
            row.update({f"busy_{k}": v for k, v in got[key]["10"].items()})
            got[key]["10"] = row
        return got

    rounds: list[dict] = []
    for r in range(repeat):
        if repeat > 1:
            say(f"  round {r + 1} of {repeat}")
        rounds.append(one_round(timed=False))
    timed_round = None
    if split:
        say("  one round more, its loops timed part by part (the split of the price)")
        timed_round = one_round(timed=True)

    def per_s(row: dict, prefix: str = "") -> float:
        return row[f"{prefix}wall_s"] / row[f"{prefix}sim_s"]

    def quickest(key: str, n: str) -> dict:
        rows = [got[key][n] for got in rounds]
        best = dict(min(rows, key=per_s))
        if "busy_wall_s" in best:  # the busy arena's figures from its own quickest round
            busy = min(rows, key=lambda row: per_s(row, "busy_"))
            best.update({k: v for k, v in busy.items() if k.startswith("busy_")})
        return best

    out = {key: {n: quickest(key, n) for n in rounds[0][key]} for key, _, _ in runs}
    if timed_round is not None:  # control period, physics in calibration steps: timed loops
        for key, _, _ in runs:
            for n, row in out[key].items():
                for ratio in ("control_calib_ratio", "physics_calib_ratio"):
                    row[ratio] = timed_round[key][n][ratio]

    def price(on: dict, off: dict, prefix: str = "") -> float:
        return per_s(on, prefix) / per_s(off, prefix)

    def split_price(on: dict, off: dict) -> dict[str, float]:
        """Where the price goes: each part's wall time per simulated second with avoidance
        less without, over the whole loop's without (``timed_parts``); ``rest`` is what no
        part holds (physics, bookkeeping, allocation, the timers). They add up to price - 1."""
        base = per_s(off)
        parts = {
            k: (on["parts_s"][k] / on["sim_s"] - off["parts_s"][k] / off["sim_s"]) / base
            for k in TIMED_PARTS
        }
        parts["rest"] = price(on, off) - 1.0 - sum(parts.values())
        return parts

    def median_round(n: str, prefix: str = "") -> tuple[dict, dict, dict]:
        """The loops (without, with the rules, ORCA alone) of the round with the median price."""
        loops = [(got["sim"][n], got["sim_orca"][n], got["sim_orca_alone"][n]) for got in rounds]
        loops.sort(key=lambda three: price(three[1], three[0], prefix))
        return loops[(len(loops) - 1) // 2]

    out["avoidance_price"] = {}
    for n in out["sim"]:
        off, on, alone = median_round(n)
        row = {"price": price(on, off), "orca_alone_price": price(alone, off)}
        if "busy_wall_s" in off:  # the 10-robot busy arena too
            off_b, on_b, alone_b = median_round(n, "busy_")
            row["busy_price"] = price(on_b, off_b, "busy_")
            row["busy_orca_alone_price"] = price(alone_b, off_b, "busy_")
        if timed_round is not None:
            on_t, off_t = timed_round["sim_orca"][n], timed_round["sim"][n]
            row["timed_price"] = price(on_t, off_t)
            row["price_parts"] = split_price(on_t, off_t)
        if repeat > 1:
            row["price_rounds"] = [price(got["sim_orca"][n], got["sim"][n]) for got in rounds]
        out["avoidance_price"][n] = row
    control_column = "  of it the control period, the physics steps" if split else ""
    say(
        "  robots  avoidance     real-time factor  wall s per robot-hour  loop in calibration "
        f"steps per physics step (calibration step){control_column}  loop/bare step"
    )
    labels = (("sim", "none"), ("sim_orca", "orca+rules"), ("sim_orca_alone", "orca alone"))
    for n in out["sim"]:
        for key, label in labels:
            r = out[key][n]
            control = ""
            if split:
                control = f"{r['control_calib_ratio']:>30.2f}, {r['physics_calib_ratio']:.2f}"
            say(
                f"  {n:>6}  {label:>10}  {r['rtf']:>16,.1f}  {r['s_per_robot_h']:>21.2f}  "
                f"{r['calib_ratio']:>14.2f} ({r['calib_step_us']:.1f} us){control}"
                f"{'':>16}{r['bare_ratio']:.2f}"
            )
        p = out["avoidance_price"][n]
        what = "paper_spatial, the run loop" if n == "10" else "busy synthetic arena"
        extra = (
            f"; busy arena {p['busy_price']:.2f}, ORCA alone {p['busy_orca_alone_price']:.2f}"
            if "busy_price" in p
            else ""
        )
        spread = ""
        if "price_rounds" in p:
            lo, hi = min(p["price_rounds"]), max(p["price_rounds"])
            spread = f" (median of {repeat} rounds: {lo:.2f} to {hi:.2f})"
        say(
            f"          price of avoidance {p['price']:.2f}{spread}, ORCA alone (traffic rules "
            f"off) {p['orca_alone_price']:.2f} ({what}{extra})"
        )
        if "price_parts" in p:
            parts = ", ".join(f"{PRICE_LABELS[k]} {v:+.2f}" for k, v in p["price_parts"].items())
            say(
                f"          split, from the timed round (its price {p['timed_price']:.2f}), in "
                f"loops without avoidance: {parts}"
            )
    for n, r in out["sim"].items():
        if "field_build_s" in r:
            say(
                f"  {n} robots, distance field: built in {r['field_build_s']:.1f} s, "
                f"{r['field_mib']:.0f} MiB; all robots x all sites {r['dist_all_ms']:.1f} ms "
                f"(straight lines {r['straight_all_ms']:.1f} ms); largest difference from the "
                f"exact query {r['field_max_err_m']:.1e} m"
            )
    return out
