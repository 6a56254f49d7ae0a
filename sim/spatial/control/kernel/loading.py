"""Loading the compiled kernel: from numba's cache, or compiled once per install.

numba writes each compiled entry point next to its module (``__pycache__``, which git ignores)
and loads it from there in later processes. Two things it does not do are done here:

- it checks the cache of an entry point against that function's own source file only, not
  against the kernel modules it calls: :func:`ensure_compiled` keeps a digest of every kernel
  module's source beside the cache and drops the cached kernel when one changed;
- a cold cache costs a compilation of about :data:`COMPILE_S` seconds: one line on stderr says
  so, and nothing is printed when the cache is warm.

The first period's types are fixed by a warm-up on a two-robot world built with the very
helpers the control period uses (``views``); compiling for other types is then disabled, so a
type that would need a second compilation is an error, not a silent half-minute.
"""

from __future__ import annotations

import hashlib
import sys
import time
from pathlib import Path

import numba
import numpy as np

from sim.spatial.control.kernel import period as kernel
from sim.spatial.control.kernel.settings import avoid_law, drive_law
from sim.spatial.control.kernel.views import (
    edges_of,
    fleet_of,
    follower_of,
    kept_for,
    outputs_for,
    poses_for,
    shapes_of,
    wishes_for,
)

COMPILE_S = 60  # 30-70 s with the event kernels, on a shared two-core machine (numba 0.68.1)
STAMP = "control-kernel.digest"  # beside numba's cache: the kernel sources it was compiled from
ENTRY_POINTS = (kernel.read_only, kernel.run_period)
KERNEL_DIR = Path(__file__).resolve().parent


def source_digest() -> str:
    """SHA-256 of every kernel module's source and of numba's version."""
    h = hashlib.sha256(numba.__version__.encode())
    for path in sorted(KERNEL_DIR.glob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def cache_dir() -> Path | None:
    """Where numba keeps the kernel's cache (None: no cache, e.g. with the JIT disabled)."""
    stats = getattr(ENTRY_POINTS[0], "stats", None)
    return None if stats is None else Path(stats.cache_path)


def is_warm(where: Path, digest: str) -> bool:
    """True if ``where`` holds a cache of every entry point compiled from these sources."""
    stamp = where / STAMP
    if not stamp.is_file() or stamp.read_text() != digest:
        return False
    return all(any(where.glob(f"{_base(fn)}-*.nbi")) for fn in ENTRY_POINTS)


def _base(fn) -> str:
    """The start of numba's cache file names of an entry point (module stem and name)."""
    return f"{fn.py_func.__module__.rsplit('.', 1)[-1]}.{fn.py_func.__qualname__}"


def drop_cache(where: Path) -> None:
    """Remove the kernel modules' cache files from ``where`` (numba's, ``*.nbi`` and ``*.nbc``;
    nothing else), so that the next call compiles from the sources as they are."""
    stems = {p.stem for p in KERNEL_DIR.glob("*.py")}
    for path in list(where.glob("*.nb[ic]")):
        if path.name.split(".", 1)[0] in stems:
            path.unlink(missing_ok=True)


def event_kernels() -> tuple:
    """The compiled functions the world calls between control periods: the planner's
    visibility test, all-pairs search and grown obstacles, a path segment's free widths, the
    event rules' geometry (``sim.spatial.plane``), the motors' control-body records, a small
    team's stall count, the states recorded."""
    from sim.spatial import fleet, motors, plane, stalls
    from sim.spatial.navigation import geodesics, segments, shapes, widths

    return (
        motors.control_records,
        stalls.sample_small,
        fleet.shown_now,
        segments.blocked_segments,
        geodesics.visibility_geodesics,
        shapes.grown_shape,
        widths.segment_sides,
        widths.free_widths,
        plane.polygon_gap,
        plane.clip_line,
        plane.path_gaps,
        plane.ways_near,
        plane.workers_by_way,
        plane.workers_near,
        plane.near_box,
        plane.way_waits,
        plane.free_place,
        plane.coming_to,
        plane.exit_clearances,
        plane.near_sites,
        plane.queue_scan,
        plane.worker_room,
    )


def events_cached() -> bool:
    """True if numba's cache holds an entry for every event kernel (one whose source changed
    since is compiled again by numba when first called)."""
    for fn in event_kernels():
        stats = getattr(fn, "stats", None)
        if stats is not None and not any(Path(stats.cache_path).glob(f"{_base(fn)}-*.nbi")):
            return False
    return True


def ensure_compiled(stream=None) -> float:
    """Make the kernel and the event kernels (:func:`event_kernels`) callable: load them from
    the cache, or compile them (once per install, saying so in one line on ``stream``,
    default stderr). Returns the seconds it took; later calls in the process return 0 at
    once."""
    if getattr(kernel.run_period, "signatures", None):  # loaded in this process already
        return 0.0
    t0 = time.perf_counter()
    where, digest = cache_dir(), source_digest()
    cold = where is not None and not is_warm(where, digest)
    if cold and where.is_dir():
        drop_cache(where)
    if cold or not events_cached():
        print(
            f"compiling the control kernel (once, about {COMPILE_S} s)",
            file=sys.stderr if stream is None else stream,
            flush=True,
        )
    warm_up()
    warm_events()
    if cold and where.is_dir():
        (where / STAMP).write_text(digest)
    for fn in ENTRY_POINTS:
        if hasattr(fn, "disable_compile"):
            fn.disable_compile()
    return time.perf_counter() - t0


def warm_events() -> None:
    """One call of each event kernel with the types the world passes it."""
    from sim.spatial import fleet, motors, plane, stalls
    from sim.spatial.navigation import geodesics, segments, shapes, widths

    z = np.array([0j, 1 + 0j, 1 + 1j, 1j])
    one = np.zeros(1, dtype=np.int64)
    four = np.zeros(4, dtype=np.int64)
    arc = np.ones(4)
    motors.control_records(z, z, arc, arc, arc, np.zeros(24), np.zeros(4), np.zeros(4), four)
    fleet.shown_now(np.ones(4, dtype=np.int8), np.zeros(4), 0.0)
    causes = np.zeros(len(stalls.CAUSES), dtype=np.int64)
    stalls.sample_small(
        np.ones(4, dtype=np.int8), np.zeros(4), four, z, np.zeros(4), np.zeros(4, dtype=bool),
        four.copy(), four.copy(), 0.05, 1.2, 20, 1.0, causes, causes.copy(),
        np.zeros((len(stalls.CAUSES), 2, 2), dtype=np.int64),
    )  # fmt: skip
    mask = np.ones(4, dtype=bool)
    xy = np.array([[0.0, 0.0], [2.0, 0.5]])
    box = np.array([[0.5, -1.0]]), np.array([[1.5, 1.0]])
    normals = np.array([[[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]]])
    segments.blocked_segments(
        xy[:1], xy[1:], one, *box, normals, np.ones((1, 4)), np.array([4]), 1e-9
    )
    geodesics.visibility_geodesics(xy, one, one + 1)
    shapes.grown_shape(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), 0.35)
    widths.segment_sides(0j, 1 + 0j, one, z, one, one + 4, z, z, one, one + 4)
    widths.free_widths(z[:1], z[1:2], z, one, z, z, one, 0.2)
    plane.polygon_gap(z, z + 3)
    plane.clip_line(0.5j, 1 + 0j, z)
    plane.path_gaps(z, z)
    plane.ways_near(z, 1.0, four, z, np.tile(z, (4, 1)), four)
    plane.workers_by_way(four, z, z, 0.5, z, 0)
    plane.near_box(z, np.zeros(4), np.zeros(4), np.ones(4))
    plane.workers_near(z, mask, four, 1.0, 0.5, np.zeros((1, 4)), 0.5)
    ends = np.zeros(4)
    plane.way_waits(z[None], one, one, np.zeros((1, 4)), z[:1], z[:1], z, z, ends, 0.0, 1.0, 0.7)
    plane.free_place(z, 0j, z, mask, z, mask, 1.0, 0.5, 0j)
    plane.coming_to(np.ones(4, dtype=np.int8), 1, z, z, 0j, 1.0)
    plane.exit_clearances(0j, z, z, 0, 1.0, mask, mask)
    plane.near_sites(z, four, z, 1.0, False)
    state = np.ones(4, dtype=np.int8)
    plane.queue_scan(state, 1, ends, mask, mask, mask, z, z, mask, mask, 0.0, 1.0, 1.0)
    corner = z.copy()
    corner.flags.writeable = False  # (as traffic.geometry.disc_corners gives them)
    plane.worker_room(0.5 + 0.5j, 0.1, corner, z + 2, np.array([0, 4]), z[:1] + 3, 1.4)


def warm_up() -> None:
    """One call of each entry point on a two-robot world with a wall, as a period makes them
    (avoidance on, a neighbour in range, every check due), from each stage."""
    from sim.scenario import DriveSpec, LawSpec, RecoverySpec
    from sim.spatial.controller import DiffDriveController
    from sim.spatial.fleet import FleetState
    from sim.spatial.law.orca import OrcaLaw
    from sim.spatial.navigation.paths import PathFollower

    drive = DriveSpec()
    controller = DiffDriveController(drive, 0.1, law=LawSpec())
    starts = np.array([[1.0, 1.0], [1.6, 1.0]])
    fleet = FleetState.at_start(starts, np.zeros(2))
    wall = [((0.0, 0.0), (3.0, 0.0))]
    follower = PathFollower(2, controller.v_max_mps, wall, drive.radius_m, cap_m=2.0)
    follower.set_path(0, np.array([[1.0, 1.0], [2.5, 1.0]]))
    fleet.state[0] = 1  # driving
    law = tuple(drive_law(controller, follower, RecoverySpec()))
    orca = tuple(avoid_law(OrcaLaw.of()))
    poses, wish, kept = poses_for(2), wishes_for(2), kept_for(2)
    pose = np.zeros((2, 6))
    pose[:, :2] = starts
    kernel.read_only(pose, fleet_of(fleet), poses)
    schedule = (True, 1, 1, 2, True, -np.inf, -np.inf, -np.inf, -np.inf, np.inf, np.inf)
    edges, shapes = edges_of(follower), shapes_of(follower)
    flags = [np.zeros(2, dtype=bool) for _ in range(6)]  # admitted .. broken (views.sites_of)
    sites = (1.5, 1.0, 0.1, 0.7, 0.55, fleet.site, fleet.site.copy(), *flags, fleet.replan, 5.0)
    for stage in (kernel.START, kernel.COMMANDS, kernel.FINISH):
        out = outputs_for(2)
        kernel.run_period(
            stage,
            0.0,
            True,
            schedule,
            0.7,
            pose,
            fleet_of(fleet),
            follower_of(follower),
            poses,
            wish,
            law,
            orca,
            edges,
            shapes,
            kept,
            sites,
            out,
        )
