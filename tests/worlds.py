"""Small worlds for the tests: one definition of each, imported by every test that needs one.

A test that needs a small hand-built scenario or pymunk world takes it from here (``from
tests.worlds import orca_world, give, at``), not from another test module; fixtures (the
``paper`` and ``tiny`` scenarios, ...) live in the ``conftest.py`` files. Every helper says
what it builds. Add a new world here when a second test module needs it; one used by a single
module stays in that module.

- The Jobs world (:func:`make_world`, :func:`orca_world`): a 20 m x 10 m arena, two task types
  (2 s and 5 s of work) every robot can do, sites where the robots start; the acts on it
  (:func:`at`, :func:`give`, :func:`set_way`, :func:`deadlock`, :func:`service`) and what is
  read back (:func:`waypoints`, :func:`done`, :func:`lane`), with its obstacles (:data:`ROOM`,
  :data:`GAP`, :data:`AISLE`, :data:`SHELF`) and the site scenes (:func:`site_crowd`,
  :func:`full_site`, :func:`slot`).
- A one-type scenario for whole-world runs (:func:`scenario`) and the auction's act on its
  world (:func:`send`); the crowd the two control periods are compared in
  (:func:`crowd_scenario`).
- Scenario files: the bundled paper scenario with one line changed (:func:`variant`) and
  paper_spatial with a short stream (:func:`small_spatial_file`); a small sweep file of the
  abstract world (:data:`ABSTRACT_SWEEP`, written by the ``abstract_file`` fixture).
- The hard cases' worlds of ``mrta hardcase`` (:func:`swap_world`, :func:`circle`,
  :func:`time_to_all_arrive`), which live in ``scenarios.experiments.hardcases`` and are
  re-exported here so that every small world is found in one place.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from scenarios.experiments.hardcases import circle, swap_world, time_to_all_arrive
from scenarios.loader import load_scenario
from sim.scenario import DriveSpec, RobotSpec, Scenario, SpatialSpec
from sim.spatial.world import PymunkWorld
from sim.states import DRIVING, WORKING
from sim.tasks import Batch
from sim.world import Completion

__all__ = [
    "ABSTRACT_SWEEP",
    "AISLE",
    "EXEC_S",
    "GAP",
    "ROOM",
    "SHELF",
    "SITE",
    "SLOT_RING",
    "at",
    "circle",
    "crowd_scenario",
    "deadlock",
    "done",
    "full_site",
    "give",
    "lane",
    "make_world",
    "orca_world",
    "scenario",
    "send",
    "service",
    "set_way",
    "site_crowd",
    "slot",
    "small_spatial_file",
    "swap_world",
    "time_to_all_arrive",
    "variant",
    "waypoints",
]

ROOT = Path(__file__).resolve().parents[1]

# ---- the Jobs world: 20 m x 10 m, two task types every robot can do ----------------------

EXEC_S = (2.0, 5.0)  # execution time of task types 0 and 1, s
ROOM = [  # a closed box round (15, 5): a site inside it has no path from outside
    ((13.0, 3.0), (17.0, 3.0), (17.0, 3.4), (13.0, 3.4)),
    ((13.0, 6.6), (17.0, 6.6), (17.0, 7.0), (13.0, 7.0)),
    ((13.0, 3.4), (13.4, 3.4), (13.4, 6.6), (13.0, 6.6)),
    ((16.6, 3.4), (17.0, 3.4), (17.0, 6.6), (16.6, 6.6)),
]
GAP = [  # a wall across x = 10 with a 1 m gap at y = 4.5..5.5 (single-lane for 0.25 m robots)
    ((9.8, 0.0), (10.2, 0.0), (10.2, 4.5), (9.8, 4.5)),
    ((9.8, 5.5), (10.2, 5.5), (10.2, 10.0), (9.8, 10.0)),
]
AISLE = [  # a corridor 2 m wide along y = 4..6 (two robots pass in it)
    ((2.0, 3.6), (18.0, 3.6), (18.0, 4.0), (2.0, 4.0)),
    ((2.0, 6.0), (18.0, 6.0), (18.0, 6.4), (2.0, 6.4)),
]
SHELF = [((8.0, 6.0), (12.0, 6.0), (12.0, 7.0), (8.0, 7.0))]  # a shelf face along y = 6


def make_world(
    starts, obstacles=(), control="scalar", seed=0, drive=None, **spatial
) -> PymunkWorld:
    """A 20 m x 10 m world with two task types (2 s and 5 s of work) every robot can do
    (``drive``: the default ``DriveSpec`` unless given)."""
    sites = (tuple(starts), tuple(starts))
    drive = DriveSpec() if drive is None else drive
    sp = SpatialSpec(20.0, 10.0, tuple(obstacles), sites, drive, **spatial)
    robots = tuple(RobotSpec(f"R{j + 1}", (0, 1), tuple(xy)) for j, xy in enumerate(starts))
    scn = Scenario("t", ("A", "B"), robots, ((1.0, 1.0),) * len(robots), EXEC_S, spatial=sp)
    world = PymunkWorld(scn, control=control, check_layout=False)  # sites where robots start
    world.reset(np.random.default_rng(seed))
    return world


def orca_world(starts, **kw) -> PymunkWorld:
    """:func:`make_world` with collision avoidance (ORCA) on."""
    w = make_world(starts, avoidance="orca", **kw)
    assert w.jobs.avoid is True
    return w


def at(world: PymunkWorld, t_s: float) -> float:
    """Set the world's clock to t_s (a whole number of physics steps) and return it."""
    world.clock.steps = round(t_s / world.dt_s)
    return world.clock.time_s


def _batch(ids, types, sites) -> Batch:
    k = len(ids)
    return Batch(0, 0, np.asarray(ids), np.asarray(types), np.zeros(k, bool), np.asarray(sites))


def give(world: PymunkWorld, robots, sites, types=None, ids=None, bids=None, xy=None) -> None:
    """Assign task k (id ids[k], type types[k], site sites[k]) to robot robots[k]."""
    k = len(robots)
    ids = list(range(k)) if ids is None else ids
    types = [0] * k if types is None else types
    bids = np.ones(k) if bids is None else np.asarray(bids, float)
    xy = world.poses()[0] if xy is None else np.asarray(xy, float)
    jobs = world.jobs
    jobs.assign(_batch(ids, types, sites), np.asarray(robots), bids, np.arange(k), xy)


def waypoints(world: PymunkWorld, j: int) -> np.ndarray:
    """Robot j's planned path as complex points (empty: it has none)."""
    fol = world.follower
    return fol.points[j, : fol.last[j] + 1]


def done(world: PymunkWorld) -> list[Completion]:
    """The completions the world's jobs have reported since the last call (handed out)."""
    out, world.jobs.done = world.jobs.done, []
    return out


def set_way(w, j: int, pts) -> None:
    """Give robot j the way ``pts`` (x + iy), standing on its first point."""
    pts = np.asarray(pts, dtype=complex)
    w.follower.set_path(j, np.column_stack([pts.real, pts.imag]))
    w.fleet.last_z_m[j] = pts[0]


def deadlock(w: PymunkWorld, z) -> None:
    """Robots 0 and 1 drive toward each other (given their tasks at their starts), now at z."""
    give(w, [0, 1], [(2.0, 5.0), (14.0, 5.0)])
    w.fleet.last_z_m[:2] = z


def lane(obstacles, j: complex, k: complex, standing=()) -> bool:
    """Is robot 0 at j single-lane toward robot 1 at k (robots 2.. stand, idle, at standing)?"""
    starts = [(4.0, 2.0), (16.0, 2.0)] + [(p.real, p.imag) for p in standing]
    w = orca_world(starts, obstacles=obstacles)
    w.fleet.state[:2] = DRIVING
    w.fleet.last_z_m[:2] = [j, k]
    return w.jobs.jams.single_lane(0, 1)


# ---- sites: service points, slots, queues ------------------------------------------------

SLOT_RING = 2 * 0.25 + 0.35  # m, radius of the ring of the 4 service slots
SITE = 10 + 5j  # the service point the site scenes come for


def slot(site: complex, k: int) -> complex:
    """Service slot k (0: east, counter-clockwise) of the service point ``site``."""
    return site + SLOT_RING * np.exp(2j * np.pi * k / 4)


def service(w: PymunkWorld, z_newcomer: complex, on_site_state: int = WORKING) -> None:
    """Robot 1 stands on the service point (10, 5); robot 0 drives there, now at z_newcomer."""
    f = w.fleet
    give(w, [0], [(10.0, 5.0)])
    f.state[1] = on_site_state
    f.last_z_m[:2] = [z_newcomer, 10 + 5j]


def site_crowd(n_close: int, xs=None) -> tuple:
    """A world whose robots 1..n all come for SITE (given their tasks where they stand); robot
    0 stands idle far off."""
    starts = [(18.0, 1.0)] + [(2.0 + 1.5 * k, 9.0) for k in range(n_close)]
    w = orca_world(starts)
    give(w, list(range(1, n_close + 1)), [(10.0, 5.0)] * n_close)
    return w, w.fleet, w.jobs


def full_site(extra_at: complex):
    """Robots 1-5 let in to SITE (its five places kept), robot 6 comes for it and is at
    ``extra_at``; robot 7 holds for another site (20 m off) right beside robot 6."""
    starts = [(18.0, 1.0)] + [(2.0 + 1.5 * k, 9.0) for k in range(6)] + [(16.0, 9.0)]
    w = orca_world(starts)
    f, jobs = w.fleet, w.jobs
    give(w, [1, 2, 3, 4, 5, 6, 7], [(10.0, 5.0)] * 6 + [(16.0, 9.0)])
    f.site[1:6] = f.last_z_m[1:6] = jobs.sites.place_points(SITE)  # each on a place of its own
    jobs.sites.admitted[1:6] = True
    f.last_z_m[6] = extra_at
    jobs.sites.holding[7] = True
    f.last_z_m[7] = extra_at + 0.5
    return w, f, jobs


# ---- whole-world runs: one task type, tasks sent as an auction would ---------------------


def scenario(starts, obstacles=(), sites=None, width=20.0, height=10.0, exec_s=2.0, **spatial):
    """One task type that every robot can do; sites default to the robots' starts."""
    sites = sites if sites is not None else starts
    sp = SpatialSpec(width, height, tuple(obstacles), (tuple(sites),), DriveSpec(), **spatial)
    robots = tuple(RobotSpec(f"R{j + 1}", (0,), tuple(xy)) for j, xy in enumerate(starts))
    return Scenario("t", ("A",), robots, ((1.0,),) * len(robots), (exec_s,), spatial=sp)


def send(world: PymunkWorld, robots, sites) -> None:
    """Give robot robots[k] a task at sites[k], as an auction would."""
    k = len(robots)
    ids = np.arange(k) + 1000 * world.steps_
    batch = Batch(0, 0, ids, np.zeros(k, int), np.zeros(k, bool), np.asarray(sites, float))
    assignment = np.full(k, -1)
    assignment[:] = robots
    world.apply(batch, assignment, np.ones(k))


def crowd_scenario(avoidance: str = "none") -> Scenario:
    """A head-on pair passing an obstacle between standing robots, and a crossing robot."""
    starts = [(4.5, 5.0), (19.0, 5.0), (9.0, 6.0), (9.0, 3.3), (6.0, 1.5), (13.0, 8.5)]
    sites = [(18.0, 5.0), (2.0, 5.0), (9.0, 6.0), (9.0, 3.3), (16.0, 8.0), (13.0, 8.5)]
    box = (((11.5, 5.6), (13.0, 5.6), (13.0, 7.2), (11.5, 7.2)),)
    sp = SpatialSpec(20.0, 10.0, box, (tuple(sites),), DriveSpec(), avoidance=avoidance)
    robots = tuple(RobotSpec(f"R{j + 1}", (0,), xy) for j, xy in enumerate(starts))
    return Scenario("crowd", ("A",), robots, ((1.0,),) * len(robots), (2.0,), spatial=sp)


# ---- scenario files ----------------------------------------------------------------------


def variant(tmp_path, old: str, new: str, name: str = "bad.toml"):
    """The bundled paper scenario with its first ``old`` replaced by ``new``, written to
    ``tmp_path / name``."""
    text = open(load_scenario("paper").source).read()
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


def small_spatial_file(tmp_path: Path, n_sets: int = 6, rounds: int = 6) -> Path:
    """paper_spatial with a short stream: ``n_sets`` sets of ``rounds`` announcements."""
    text = (ROOT / "scenarios" / "data" / "paper_spatial.toml").read_text()
    for key, value in (
        ("n_sets", n_sets),
        ("rounds_per_set", rounds),
        ("learn_sets", n_sets // 2),
        ("test_sets", n_sets - n_sets // 2),
    ):
        lines = [ln for ln in text.splitlines() if ln.split("=")[0].strip() == key]
        assert len(lines) == 1, key
        text = text.replace(lines[0], f"{key} = {value}")
    path = tmp_path / f"small_{n_sets}x{rounds}.toml"
    path.write_text(text)
    return path


SHORT_SWEEP = """
[fixed]
"stream.n_sets" = 6
"stream.rounds_per_set" = 6
"stream.learn_sets" = 4
"stream.test_sets" = 3
"experience.n_min" = 3
"""

ABSTRACT_SWEEP = (  # QL-MRTA and ExpT-MRTA over 3 refusal thresholds, 5 seeds: 30 short runs
    """
[sweep]
name = "abstract"
scenarios = ["paper"]
allocators = ["ql", "expt"]
seeds = 5
"""
    + SHORT_SWEEP
    + """
[grid]
"experience.delta_u" = [0.05, 0.3, 0.5]
"""
)
