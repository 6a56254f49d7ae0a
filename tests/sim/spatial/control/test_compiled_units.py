"""The compiled kernel's parts (``sim.spatial.control.kernel``) against their definitions.

- the velocity program where it has a solution: the numpy law's ``solve`` (the nearest point);
- where it has none, the rule the kernel brings (RVO2's linearProgram3, walls hard): its worst
  violation of the robots' lines is the least there is, bracketed by two linear programs over
  the speed disc drawn as a polygon inside it and one outside it (scipy's ``linprog``);
- the k nearest robots against sorting all of them, ties included;
- the nearest obstacle point and a segment's free widths against ``PathFollower``'s;
- the cache: a changed kernel source invalidates it, and only the kernel's files are dropped.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import linprog

from sim.scenario import DriveSpec
from sim.spatial.control.kernel import loading
from sim.spatial.control.kernel.freewidth import Shapes, free_widths
from sim.spatial.control.kernel.linprog import nearest_velocity
from sim.spatial.control.kernel.neighbours import build_grid, k_nearest
from sim.spatial.control.kernel.obstacles import Edges, to_obstacle
from sim.spatial.control.kernel.views import edges_of, shapes_of
from sim.spatial.law import orca as law
from sim.spatial.navigation.paths import PathFollower

V_MAX = 1.5  # m/s


@pytest.fixture(scope="module", autouse=True)
def kernel():
    """The kernel loaded (compiled once per install)."""
    loading.ensure_compiled()


def random_lines(rng: np.random.Generator, count: int, low: float, high: float):
    """``count`` random half-planes n . u >= c: unit normals, offsets in [low, high]."""
    normal = np.exp(1j * rng.uniform(-np.pi, np.pi, count))
    return normal.astype(complex), rng.uniform(low, high, count)


def solve_kernel(normal, offset, n_hard, pref):
    """The kernel's velocity program (walls, the first ``n_hard`` lines, hard)."""
    buf_n, buf_c = np.zeros(len(normal), complex), np.zeros(len(normal))
    return nearest_velocity(
        np.ascontiguousarray(normal),
        np.ascontiguousarray(offset),
        len(normal),
        n_hard,
        complex(pref),
        V_MAX,
        buf_n,
        buf_c,
    )


SIDES = 240  # the speed disc as a polygon: inside it, or round it (1e-4 m/s apart)


def minimax(normal, offset, n_hard, outside: bool):
    """The least worst violation max_j (c_j - n_j . u) of the soft lines (all but the first
    ``n_hard``, which are kept) over u in a regular polygon inside the speed disc (or round
    it): a linear program in (u_x, u_y, s). None where the hard lines leave nothing; 0
    without soft lines where they leave something."""
    a = np.column_stack([-normal.real, -normal.imag, np.zeros(len(normal))])
    a[n_hard:, 2] = -1.0  # soft: c - n . u <= s
    angles = 2.0 * np.pi * np.arange(SIDES) / SIDES
    apothem = V_MAX if outside else V_MAX * math.cos(math.pi / SIDES)
    poly = np.column_stack([np.cos(angles), np.sin(angles), np.zeros(SIDES)])
    rows = np.vstack([a, poly])
    bound = np.concatenate([-offset, np.full(SIDES, apothem)])
    soft = n_hard < len(normal)
    bounds = [(None, None)] * 2 + [(None, None) if soft else (0.0, 0.0)]
    fit = linprog([0, 0, 1.0 if soft else 0.0], A_ub=rows, b_ub=bound, bounds=bounds)
    return fit.x[2] if fit.status == 0 else None


def worst_soft(normal, offset, n_hard, u) -> float:
    return float((offset[n_hard:] - (u * normal[n_hard:].conj()).real).max())


def test_feasible_programs_give_the_numpy_laws_nearest_velocity():
    rng = np.random.default_rng(3)
    checked = 0
    for _ in range(3000):
        normal, offset = random_lines(rng, int(rng.integers(1, 14)), -1.5, 0.5)
        pref = complex(*rng.uniform(-2.0, 2.0, 2))
        want = law.solve(normal[None], offset[None], np.array([pref]), V_MAX)[0]
        if (offset - (want * normal.conj()).real).max() > 1e-9 or abs(want) > V_MAX * 1.000001:
            continue  # no solution: the other rule
        got = solve_kernel(normal, offset, 0, pref)
        assert abs(got - want) < 1e-12
        checked += 1
    assert checked > 1500


@pytest.mark.parametrize("n_hard", [0, 1, 3])
def test_infeasible_programs_break_the_robots_lines_least_keeping_the_walls(n_hard, report_line):
    """Where no velocity keeps every line, the kernel's velocity keeps the hard lines and the
    disc and its worst violation of the others is the least possible: between the optimum
    over a polygon round the disc and the one over a polygon inside it."""
    rng = np.random.default_rng(5 + n_hard)
    checked, gain = 0, []
    while checked < 100:
        count = n_hard + int(rng.integers(2, 12))
        normal, offset = random_lines(rng, count, -1.6, 1.6)
        offset[:n_hard] = rng.uniform(-1.5, 0.3, n_hard)  # walls the disc can keep
        inner = minimax(normal, offset, n_hard, outside=False)
        if inner is None or inner <= 1e-9:
            continue  # walls leave nothing, or the program has a solution
        outer = minimax(normal, offset, n_hard, outside=True)
        pref = complex(*rng.uniform(-2.0, 2.0, 2))
        u = solve_kernel(normal, offset, n_hard, pref)
        assert abs(u) <= V_MAX * (1.0 + 1e-9)
        if n_hard:
            assert (offset[:n_hard] - (u * normal[:n_hard].conj()).real).max() <= 1e-9
        worst = worst_soft(normal, offset, n_hard, u)
        assert outer - 1e-9 <= worst <= inner + 1e-9
        old = law.solve(normal[None], offset[None], np.array([pref]), V_MAX)[0]
        gain.append(worst_soft(normal, offset, n_hard, old) / max(worst, 1e-12))
        checked += 1
    report_line(
        f"linearProgram3 with {n_hard} hard lines: {checked} random infeasible programs, the "
        f"least worst violation each time; the numpy law's candidate minimax breaks the robots' "
        f"lines by {np.mean(gain):.2f}x as much on average (worst {np.max(gain):.2f}x)"
    )


def test_a_program_whose_walls_leave_nothing_breaks_every_line_least():
    rng = np.random.default_rng(9)
    checked = 0
    while checked < 60:
        normal, offset = random_lines(rng, int(rng.integers(3, 9)), -2.5, 2.5)
        if minimax(normal[:2], offset[:2], 2, outside=True) is not None:
            continue  # the two walls alone leave something
        u = solve_kernel(normal, offset, 2, 0j)
        inner = minimax(normal, offset, 0, outside=False)
        outer = minimax(normal, offset, 0, outside=True)
        assert outer - 1e-9 <= worst_soft(normal, offset, 0, u) <= inner + 1e-9
        checked += 1


def test_the_meeting_rule_is_the_numpy_laws():
    """The kernel's test whether a robot may take the right-hand bias in a meeting
    (``avoid.meeting``) against the numpy law's (``orca.meeting``) on 2000 random robots with
    one to four neighbours each, at three meeting angles: the same decision for every robot,
    and both decisions taken at each angle."""
    from sim.scenario import OrcaSpec
    from sim.spatial.control.kernel.avoid import meeting

    rng = np.random.default_rng(11)
    for deg in (10.0, 30.0, 90.0):
        p = law.OrcaLaw.of(OrcaSpec(bias_meet_deg=deg))
        got, want = [], []
        for _ in range(2000):
            k = int(rng.integers(1, 5))
            z = rng.uniform(-2, 2, k + 1) + 1j * rng.uniform(-2, 2, k + 1)
            vel = rng.uniform(-1, 1, k + 1) + 1j * rng.uniform(-1, 1, k + 1)
            pref = rng.uniform(-1, 1) + 1j * rng.uniform(-1, 1)
            near = np.arange(1, k + 1)
            idx, mask = near[None, :], np.ones((1, k), dtype=bool)
            want.append(
                bool(law.meeting(z, vel, np.array([0]), idx, mask, np.array([pref]), p=p)[0])
            )
            got.append(meeting(0, z, vel, pref, near, k, p.cos_meet))
        assert got == want
        assert 0 < sum(got) < len(got)


def test_k_nearest_are_a_stable_sort_of_all_robots_within_range():
    rng = np.random.default_rng(1)
    for trial in range(40):
        m = int(rng.integers(2, 300))
        if trial % 2:  # on a lattice: many equal distances
            z = (rng.integers(0, 12, m) + 1j * rng.integers(0, 12, m)) * 0.5
        else:
            z = rng.uniform(0.0, 30.0, m) + 1j * rng.uniform(0.0, 30.0, m)
        z = z.astype(complex)
        reach, k = 3.1, 10
        grid = build_grid(z, reach)
        idx, dist, scratch = np.zeros(k, np.int64), np.zeros(k), np.zeros(m, np.int64)
        for i in range(m):
            count = k_nearest(grid, z, i, reach, k, idx, dist, scratch)
            d = np.abs(z - z[i])
            d[i] = np.inf
            order = np.argsort(d, kind="stable")
            want = order[d[order] < reach][:k]
            np.testing.assert_array_equal(idx[:count], want)


def grid_holds_every_robot_once(grid, z):
    """The grid's tables are whole: counts rising to m, ``order`` a permutation, and each
    robot with a usable pose in the cell its coordinates give."""
    m = len(z)
    assert grid.nx >= 1 and grid.ny >= 1 and grid.nx * grid.ny <= 4 * m + 16
    assert len(grid.start) == grid.nx * grid.ny + 1
    assert grid.start[0] == 0 and grid.start[-1] == m and np.all(np.diff(grid.start) >= 0)
    np.testing.assert_array_equal(np.sort(grid.order), np.arange(m))
    for c in range(grid.nx * grid.ny):
        for i in grid.order[grid.start[c] : grid.start[c + 1]]:
            x, y = z[i].real, z[i].imag
            if abs(x) < 1e300 and abs(y) < 1e300:
                cx = min(int((x - grid.x0) * grid.inv), grid.nx - 1)
                cy = min(int((y - grid.y0) * grid.inv), grid.ny - 1)
                assert c == cy * grid.nx + cx


@pytest.mark.parametrize(
    "bad",
    [
        complex(np.nan, 3.0),
        complex(2.0, np.nan),
        complex(np.inf, 0.0),
        complex(0, -np.inf),
        complex(1e308, -1e308),
        complex(5e299, 1.0),
    ],
)
def test_a_broken_pose_cannot_take_the_grid_outside_its_tables(bad):
    """A pose gone NaN, infinite or absurdly far (a hostile setting, a blown-up body) is binned
    at the grid's edge: the tables stay whole, and the other robots' neighbours are theirs."""
    rng = np.random.default_rng(7)
    z = rng.uniform(0.0, 20.0, 40) + 1j * rng.uniform(0.0, 20.0, 40)
    reach, k = 3.1, 10
    clean = build_grid(z, reach)
    broken = np.append(z, bad)
    grid = build_grid(broken, reach)
    grid_holds_every_robot_once(grid, broken)
    idx, dist, scratch = np.zeros(k, np.int64), np.zeros(k), np.zeros(41, np.int64)
    want_idx, want_dist = np.zeros(k, np.int64), np.zeros(k)
    for i in range(40):
        count = k_nearest(grid, broken, i, reach, k, idx, dist, scratch)
        want = k_nearest(clean, z, i, reach, k, want_idx, want_dist, scratch)
        np.testing.assert_array_equal(idx[:count], want_idx[:want])
    assert 0 <= k_nearest(grid, broken, 40, reach, k, idx, dist, scratch) <= k  # its own query


@pytest.mark.parametrize("side", [5e-324, 1e-300, 0.0, -1.0, np.nan, np.inf])
def test_any_cell_side_gives_a_whole_grid(side):
    """A cell side too small to count cells in (their number overflows an integer), zero,
    negative, NaN or infinite still gives whole tables: cells are widened, or one serves all."""
    rng = np.random.default_rng(8)
    z = rng.uniform(0.0, 25.0, 30) + 1j * rng.uniform(0.0, 9.0, 30)
    grid = build_grid(z, side)
    grid_holds_every_robot_once(grid, z)
    if not side > 0.0:
        assert grid.nx == grid.ny == 1


def follower_with_boxes(rng: np.random.Generator, boxes: int) -> PathFollower:
    """A follower in a 40 m square with ``boxes`` random boxes (an edge grid from 48 edges)."""
    polys = []
    for x, y in rng.uniform(2.0, 38.0, (boxes, 2)):
        w, h = rng.uniform(0.3, 3.0, 2)
        polys.append(((x, y), (x + w, y), (x + w, y + h), (x, y + h)))
    walls = [((0, 0), (40, 0)), ((40, 0), (40, 40)), ((40, 40), (0, 40)), ((0, 40), (0, 0))]
    return PathFollower(1, V_MAX, [*polys, *walls], DriveSpec().radius_m)


@pytest.mark.parametrize("boxes", [3, 40])
def test_nearest_obstacle_point_is_the_followers(boxes):
    rng = np.random.default_rng(boxes)
    fol = follower_with_boxes(rng, boxes)
    assert (fol.cells_ is not None) == (boxes == 40)
    edges = Edges(*edges_of(fol))
    z = rng.uniform(-5.0, 45.0, 400) + 1j * rng.uniform(-5.0, 45.0, 400)
    want = fol.to_obstacle(z)
    got = np.array([to_obstacle(complex(p), edges) for p in z])
    np.testing.assert_array_equal(got, want)


def test_obstacle_points_in_reach_are_the_followers():
    """The kernel's obstacle points of a robot (``[spatial.orca] wall_lines`` above 1) against
    ``PathFollower.obstacle_points`` at 2000 random points in and round a square of 40 random
    boxes, at most 1 to 6 points within 1.2 m, from each grid cell's edges in reach and from
    every edge: bit for bit, and some points get more than one."""
    from sim.spatial.control.kernel.obstacles import obstacle_points

    rng = np.random.default_rng(9)
    fol = follower_with_boxes(rng, 40)
    grid = Edges(*edges_of(fol, 1.2))  # each cell's edges in reach ...
    assert 0 < grid.reach.shape[1] < len(grid.e0)
    every = grid._replace(reach=np.zeros((0, 0), dtype=np.int64))  # ... or all of them
    z = rng.uniform(-2.0, 42.0, 2000) + 1j * rng.uniform(-2.0, 42.0, 2000)
    e = len(grid.e0)
    several = 0
    for count in (1, 2, 6):
        want = fol.obstacle_points(z, 1.2, count)
        for edges in (grid, every):
            got = np.full((len(z), count), np.inf + 0j)
            for i, p in enumerate(z):
                buf = (np.zeros(e, complex), np.zeros(e), got[i])
                got[i, obstacle_points(complex(p), edges, 1.2, *buf) :] = np.inf
            np.testing.assert_array_equal(got, want)
        several += int(np.isfinite(want[:, 1:]).any(axis=1).sum()) if count > 1 else 0
    assert several > 50


def test_free_widths_are_the_followers():
    rng = np.random.default_rng(4)
    fol = follower_with_boxes(rng, 25)
    shapes = Shapes(*shapes_of(fol))
    a = rng.uniform(1.0, 39.0, 300) + 1j * rng.uniform(1.0, 39.0, 300)
    b = a + rng.uniform(-4.0, 4.0, 300) + 1j * rng.uniform(-4.0, 4.0, 300)
    want = fol._free(a, b)
    got = [
        free_widths(complex(p), complex(q), shapes, fol.radius_m) for p, q in zip(a, b, strict=True)
    ]
    np.testing.assert_allclose(np.array(got), want, rtol=0.0, atol=1e-12)  # hypot's last bit


def test_a_changed_kernel_source_makes_the_cache_cold(tmp_path, monkeypatch):
    digest = loading.source_digest()
    for fn in loading.ENTRY_POINTS:
        (tmp_path / f"{loading._base(fn)}-42.py311.nbi").write_bytes(b"")
    (tmp_path / loading.STAMP).write_text(digest)
    assert loading.is_warm(tmp_path, digest)
    assert not loading.is_warm(tmp_path, "another source")
    (tmp_path / "period.run_period-42.py311.1.nbc").write_bytes(b"")
    (tmp_path / "elsewhere.f-1.py311.nbi").write_bytes(b"")
    (tmp_path / "period.cpython-311.pyc").write_bytes(b"")
    loading.drop_cache(tmp_path)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == [loading.STAMP, "elsewhere.f-1.py311.nbi", "period.cpython-311.pyc"]
    assert not loading.is_warm(tmp_path, digest)


def test_the_kernel_is_compiled_for_one_set_of_types():
    """Each entry point has one signature and compiles no other: a type that would need a
    second compilation (half a minute) is an error instead."""
    from sim.spatial.control.kernel import period

    for fn in loading.ENTRY_POINTS:
        assert len(fn.signatures) == 1
    with pytest.raises(TypeError):
        period.read_only(np.zeros((2, 6), dtype=np.float32), (), ())


def test_ensure_compiled_warms_the_event_kernels_with_the_types_runs_pass():
    """In a fresh process, ``ensure_compiled`` compiles (or loads) every event kernel, and
    short runs with avoidance in the paper arena and the warehouse (traffic rules, site
    queues, look-ahead, planning round robots) add no signature: a run compiles nothing more
    after the one line, and CI's warm cache is complete."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    code = """
import json
from sim.spatial.control.kernel import loading
from scenarios.experiments.protocol import RunSpec, execute
loading.ensure_compiled()
before = {loading._base(f): len(f.signatures) for f in loading.event_kernels()}
short = (("stream.n_sets", 2), ("stream.learn_sets", 1), ("stream.test_sets", 1))
for name in ("paper_spatial", "warehouse"):
    execute(RunSpec(name, "market", "distance", 0, short))
after = {loading._base(f): len(f.signatures) for f in loading.event_kernels()}
print(json.dumps([before, after, loading.events_cached()]))
"""
    root = Path(__file__).resolve().parents[4]
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=True
    )
    before, after, cached = json.loads(out.stdout.strip().splitlines()[-1])
    assert len(before) == 22 and all(n == 1 for n in before.values()), before
    assert after == before
    assert cached
