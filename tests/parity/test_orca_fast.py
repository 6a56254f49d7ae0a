"""The fast ORCA paths (``sim.spatial.law.orca``: the staged ``solve``;
``sim.spatial.control.orca_small``: ``avoid_small`` and its screen ``may_bind``) against the law as
it was computed before them, kept here as the reference: every candidate enumerated for every row
(``solve_reference``) inside the array ``avoid`` of commit 5f5188e (``avoid_reference``). Both must
give the same commands bit for bit: the golden runs with avoidance on (``tests/golden/``)
hold them to it too.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.scenario import LawSpec, OrcaSpec
from sim.spatial.control import orca_small
from sim.spatial.law import orca
from sim.spatial.law.orca import (
    _BIG,
    DEFAULT,
    forward_speed,
    half_planes,
    neighbour_table,
    obstacle_plane,
    orca_range_m,
)

# the settings' defaults (sim.scenario), under the names these tests use
COS_TURN = math.cos(LawSpec().turn_in_place_rad)
HEADING_GAIN = LawSpec().heading_gain
BIAS_ROOM_M = DEFAULT.bias_room_m
KEEP_RIGHT = DEFAULT.keep_right
MEET_DEG = OrcaSpec().bias_meet_deg
LANE_AIR_M = OrcaSpec().lane_air_m
LANE_NARROW_M = OrcaSpec().lane_narrow_m
LANE_NEAR_M = OrcaSpec().lane_near_m
MARGIN_M = OrcaSpec().margin_m
ROBOT_SLACK_MPS = OrcaSpec().robot_slack_mps
TAU_OBSTACLE_S = OrcaSpec().tau_obstacle_s
TAU_S = OrcaSpec().tau_s
WALL_GAP_M = OrcaSpec().wall_gap_m
WALL_SLACK_MPS = OrcaSpec().wall_slack_mps


def solve_reference(
    normal: np.ndarray, offset: np.ndarray, pref: np.ndarray, v_max: float, rows: int = 250
) -> np.ndarray:
    """Velocity nearest ``pref`` with |u| <= ``v_max`` and n . u >= c for every line, per row;
    where no velocity satisfies every line, the candidate that violates them least. Every
    row's first candidates are all rows' ``pref`` scaled as its own (the law's pool), so the
    rows go ``rows`` at a time (the same arithmetic per row: memory, not results).

    Args:
        normal, offset: (n, L) unit normals and offsets (unused lines: offset -inf or large
            negative); pref: (n,) preferred velocities.
    """
    parts = [
        _solve_reference_rows(
            normal[i : i + rows], offset[i : i + rows], pref[i : i + rows], pref, v_max
        )
        for i in range(0, len(pref), rows)
    ]
    return np.concatenate(parts) if parts else np.zeros(0, dtype=complex)


def _solve_reference_rows(normal, offset, pref, pool, v_max):
    """:func:`solve_reference` for some rows, with ``pool`` every row's ``pref``."""
    n, c = normal, offset
    big = c > -_BIG / 2
    speed = np.abs(pref)
    cands = [pool * np.minimum(1.0, v_max / np.maximum(speed, 1e-12))[:, None]]
    along = (pref[:, None] * n.conj()).real
    cands.append(pref[:, None] + (c - along) * n)
    half = np.sqrt(np.maximum(v_max * v_max - c * c, 0.0))
    foot = c * n
    cands += [foot + half * 1j * n, foot - half * 1j * n]
    lines = n.shape[1]
    if lines > 1:
        a, b = np.triu_indices(lines, 1)
        na, nb, ca, cb = n[:, a], n[:, b], c[:, a], c[:, b]
        det = (na.conj() * nb).imag
        ok = np.abs(det) > 1e-9
        det = np.where(ok, det, 1.0)
        x = (ca * nb.imag - cb * na.imag) / det
        y = (na.real * cb - nb.real * ca) / det
        cands.append(np.where(ok & big[:, a] & big[:, b], x + 1j * y, np.nan))
    cands.append(np.zeros((len(pref), 1), dtype=complex))
    cand = np.concatenate(cands, axis=1)  # (n, C)
    cand = np.where(np.isfinite(cand), cand, 0.0)
    viol = (c[:, None, :] - (cand[:, :, None] * n[:, None, :].conj()).real).max(axis=2)
    outside = np.abs(cand) > v_max * (1.0 + 1e-9)
    viol = np.where(outside, np.inf, viol)
    feasible = viol <= 1e-9
    score = np.where(feasible, np.abs(cand - pref[:, None]), np.inf)
    best = np.where(feasible.any(axis=1), score.argmin(axis=1), viol.argmin(axis=1))
    return cand[np.arange(len(pref)), best]


def avoid_reference(
    z: np.ndarray,
    vel: np.ndarray,
    h: np.ndarray,
    rows: np.ndarray,
    pref: np.ndarray,
    v_want: np.ndarray,
    steering: np.ndarray,
    radius_m: float,
    v_max: float,
    dt_s: float,
    to_obstacle,
    lanes=None,
):
    """``sim.spatial.law.orca.avoid`` of commit 5f5188e (then ``sim.orca.avoid``), before the
    staged solve: the oracle; its right-hand bias since taken only where the body has more
    than ``BIAS_ROOM_M`` of room to the nearest obstacle and in a meeting (a neighbour within
    ``MEET_DEG`` of the preferred velocity relative to the neighbour's; no robot has stood
    here), and its forward program with the slacks, as the law now does. Arguments and result
    as ``sim.spatial.law.orca.avoid``."""
    reach = orca_range_m(radius_m, v_max)
    table = neighbour_table(z, rows, reach)
    if table is None:
        return None
    idx, mask = table
    keep = mask.any(axis=1)
    rows, idx, mask = rows[keep], idx[keep], mask[keep]
    pref, v_want = pref[keep], v_want[keep]
    r_eff = radius_m + MARGIN_M
    zi, vi = z[rows], vel[rows]
    share = np.where(steering[idx], 0.5, 1.0)
    normal, offset = half_planes(
        z[idx] - zi[:, None],
        vi[:, None] - vel[idx],
        vi[:, None],
        share,
        2.0 * r_eff,
        1.0 / TAU_S,
        1.0 / dt_s,
    )
    normal = np.where(mask, normal, 1.0)
    offset = np.where(mask, offset, -_BIG)
    hi = h[rows]
    plan = v_want * hi
    bind = (offset - (plan[:, None] * normal.conj()).real).max(axis=1) > 1e-9
    if not bind.any():
        return None
    normal, offset, hi, pref = normal[bind], offset[bind], hi[bind], pref[bind]
    k_robots = normal.shape[1]
    ob = to_obstacle(zi[bind])
    meets = [  # a neighbour within MEET_DEG of the preferred velocity relative to its own
        any(
            abs(np.angle((z[k] - z[i]) / (p - vel[k]))) < math.radians(MEET_DEG)
            for k, real in zip(ks, ms, strict=True)
            if real and p != vel[k]
        )
        for i, ks, ms, p in zip(rows[bind], idx[bind], mask[bind], pref, strict=True)
    ]
    room = np.abs(ob) - radius_m > BIAS_ROOM_M
    pref = pref * np.where(room & np.array(meets, dtype=bool), KEEP_RIGHT, 1.0)
    on, oc = obstacle_plane(ob, r_eff + WALL_GAP_M, 1.0 / TAU_OBSTACLE_S)
    normal = np.concatenate([normal, on[:, None]], axis=1)
    offset = np.concatenate([offset, oc[:, None]], axis=1)
    if lanes is not None:
        left, room_l, room_r = lanes(zi[bind], rows[bind])
        real = (np.abs(left) > 0.5) & (room_l + room_r < LANE_NARROW_M)
        real &= np.abs(ob) < radius_m + LANE_NEAR_M  # ... and between walls here, not past them
        lane_n = np.column_stack([np.where(real, -left, 1.0), np.where(real, left, 1.0)])
        room = np.column_stack([room_l, room_r]) - LANE_AIR_M
        lane_c = np.where(real[:, None] & np.isfinite(room), -room / TAU_OBSTACLE_S, -_BIG)
        normal = np.concatenate([normal, lane_n], axis=1)
        offset = np.concatenate([offset, lane_c], axis=1)
    u = solve_reference(normal, offset, pref, v_max)
    local = u * hi.conj()
    err = np.arctan2(local.imag, local.real)
    align = np.clip((np.cos(err) - COS_TURN) / (1.0 - COS_TURN), 0.0, 1.0)
    slack = np.repeat([ROBOT_SLACK_MPS, WALL_SLACK_MPS], [k_robots, normal.shape[1] - k_robots])
    v = forward_speed(normal, offset, hi, np.abs(u) * align, v_max, slack)
    return rows[bind], v, err * HEADING_GAIN


WALLS = np.array([[0.0, 6.0], [6.0, 6.0 + 6.0j], [6.0 + 6.0j, 6.0j], [6.0j, 0.0], [2 + 2j, 3 + 2j]])


def to_obstacle(z):
    """From each point to the nearest point of the walls and a short bar inside them."""
    e0, d = WALLS[:, 0], WALLS[:, 1] - WALLS[:, 0]
    t = np.clip(((z[:, None] - e0) * d.conj()).real / (d * d.conj()).real, 0.0, 1.0)
    near = e0 + t * d - z[:, None]
    return near[np.arange(len(z)), np.abs(near).argmin(axis=1)]


def to_obstacle_one(z):
    return complex(to_obstacle(np.array([z]))[0])


def scene(rng, m, lanes_on=True, crowd_m=6.0):
    """A random moment of m robots: positions (some overlapping), velocities, headings, who
    steers, what they prefer and plan, and per-robot lane rooms (some narrow, some infinite)."""
    z = rng.uniform(0.3, crowd_m - 0.3, m) + 1j * rng.uniform(0.3, crowd_m - 0.3, m)
    if m > 2:
        z[1] = z[0] + 0.3 * np.exp(1j * rng.uniform(0, 2 * np.pi))  # a pair in contact
    h = np.exp(1j * rng.uniform(0, 2 * np.pi, m))
    speed = rng.uniform(-0.3, 1.0, m) * (rng.random(m) < 0.8)
    vel = speed * h * np.exp(1j * rng.normal(0, 0.2, m))
    steering = rng.random(m) < 0.7
    rows = steering.nonzero()[0]
    pref = rng.uniform(0, 1.3, len(rows)) * np.exp(1j * rng.uniform(0, 2 * np.pi, len(rows)))
    v_want = rng.uniform(-0.2, 1.0, len(rows))
    left = np.exp(1j * rng.uniform(0, 2 * np.pi, m)) * (rng.random(m) < 0.9)
    room_l, room_r = rng.uniform(-0.05, 0.6, m), rng.uniform(-0.05, 0.6, m)
    room_l[rng.random(m) < 0.2] = np.inf

    def lanes(pts, idx):
        return left[idx], room_l[idx], room_r[idx]

    return z, vel, h, rows, pref, v_want, steering, (lanes if lanes_on else None)


def same(got, want):
    """The same robots and the same (v, omega), bit for bit."""
    if want is None:
        return got is None
    return got is not None and all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))


@pytest.mark.slow
def test_staged_solve_matches_the_enumeration_on_random_programs():
    rng = np.random.default_rng(11)
    for lines in (1, 2, 4, 9):
        n = 4000
        normal = np.exp(1j * rng.uniform(0, 2 * np.pi, (n, lines)))
        offset = rng.uniform(-1.2, 0.8, (n, lines))
        offset[rng.random((n, lines)) < 0.2] = -_BIG  # unused lines
        pref = rng.uniform(0, 1.5, n) * np.exp(1j * rng.uniform(0, 2 * np.pi, n))
        want = solve_reference(normal, offset, pref, 1.0)
        assert np.array_equal(orca.solve(normal, offset, pref, 1.0), want)
        assert np.array_equal(orca.solve_enumerated(normal, offset, pref, 1.0), want)


def test_the_enumeration_in_row_blocks_gives_the_same_rows(monkeypatch):
    rng = np.random.default_rng(12)
    n, lines = 300, 5
    normal = np.exp(1j * rng.uniform(0, 2 * np.pi, (n, lines)))
    offset = rng.uniform(-1.2, 0.8, (n, lines))
    pref = rng.uniform(0, 1.5, n) * np.exp(1j * rng.uniform(0, 2 * np.pi, n))
    whole = orca.solve_enumerated(normal, offset, pref, 1.0)
    calls = []
    inner = orca._enumerate

    def spy(*args):
        calls.append(len(args[2]))
        return inner(*args)

    monkeypatch.setattr(orca, "_enumerate", spy)
    block = 7 * (n + 26) * lines  # 7 rows: n + 3 L + L (L - 1) / 2 + 1 candidates of L lines
    assert np.array_equal(orca.solve_enumerated(normal, offset, pref, 1.0, cells=block), whole)
    assert calls == [7] * (n // 7) + [n % 7]


def one_line_rows(normal, offset, pref, v_max):
    """Rows whose optimum the staged solve finds without enumerating, by the docstring's
    argument: the preferred velocity on the speed disc keeps every line, or for some line it
    breaks, the point of that line inside the disc nearest the preferred velocity (its
    projection, or the nearer end of the line's chord of the disc) keeps every line."""
    out = []
    for r in range(len(pref)):
        n, c, p = normal[r], offset[r], pref[r]
        u = p * min(1.0, v_max / max(abs(p), 1e-12))
        broken = c - (u * n.conj()).real > 1e-9
        if not broken.any():
            out.append(r)
            continue
        for j in broken.nonzero()[0]:
            q = p + (c[j] - (p * n[j].conjugate()).real) * n[j]
            if abs(q) > v_max * (1 + 1e-9):
                half = np.sqrt(max(v_max * v_max - c[j] * c[j], 0.0))
                ends = (c[j] * n[j] + half * 1j * n[j], c[j] * n[j] - half * 1j * n[j])
                q = min(ends, key=lambda e: abs(e - p))
            keeps = (c - (q * n.conj()).real).max() <= 1e-9 and abs(q) <= v_max * (1 + 1e-9)
            if keeps:
                out.append(r)
                break
    return out


@pytest.mark.slow
@pytest.mark.parametrize("v_max", [1.0, 1.5])
def test_the_staged_solve_enumerates_only_rows_no_single_line_answers(monkeypatch, v_max):
    """The staged solve is the enumeration's answer for every row (at two top speeds), and it
    hands to the enumeration exactly the rows that neither the preferred velocity nor one
    line's nearest point answers: a stage that found less would give the same velocities,
    only slower, and no comparison of results sees that."""
    rng = np.random.default_rng(17)
    n_rows, lines = 3000, 4
    normal = np.exp(1j * rng.uniform(0, 2 * np.pi, (n_rows, lines)))
    offset = rng.uniform(-1.2, 0.8, (n_rows, lines)) * v_max
    offset[rng.random((n_rows, lines)) < 0.2] = -_BIG
    pref = rng.uniform(0, 1.5, n_rows) * v_max * np.exp(1j * rng.uniform(0, 2 * np.pi, n_rows))
    sent = []
    inner = orca.solve_enumerated

    def spy(n, c, p, v, pool=None):
        if pool is not None and pool.ndim == 2:  # the first call: each row on its own
            sent.extend(p.tolist())
        return inner(n, c, p, v, pool=pool)

    monkeypatch.setattr(orca, "solve_enumerated", spy)
    got = orca.solve(normal, offset, pref, v_max)
    assert np.array_equal(got, solve_reference(normal, offset, pref, v_max))
    staged = set(one_line_rows(normal, offset, pref, v_max))
    enumerated = [r for r in range(n_rows) if r not in staged]
    assert sent == pref[enumerated].tolist()
    assert 0.1 * n_rows < len(enumerated) < 0.9 * n_rows  # both kinds, many times


@pytest.mark.parametrize("m", [2, 3, 10, 24])
@pytest.mark.parametrize("lanes_on", [True, False])
def test_avoid_and_avoid_small_match_the_reference_on_random_scenes(m, lanes_on):
    rng = np.random.default_rng(m + 100 * lanes_on)
    bound = 0
    for _ in range(150):
        z, vel, h, rows, pref, v_want, steering, lanes = scene(rng, m, lanes_on)
        args = (z, vel, h, rows, pref, v_want, steering, 0.25, 1.0, 0.1, to_obstacle, lanes)
        want = avoid_reference(*args)
        assert same(orca.avoid(*args), want)
        assert same(orca_small.avoid_small(*args), want)
        bound += want is not None
    assert bound > 12  # the scenes do bind


@pytest.mark.parametrize("m", [2, 10, 24])
def test_the_screen_skips_exactly_robots_with_no_binding_half_plane(m):
    """Every robot ``may_bind`` leaves out has no binding half-plane in the law (the reference
    on that robot alone returns None), and every robot the law steers is kept."""
    rng = np.random.default_rng(3 + m)
    skipped = kept = 0
    for _ in range(200):
        z, vel, h, rows, pref, v_want, steering, lanes = scene(rng, m, True, crowd_m=3.0 * m**0.5)
        args = (0.25, 1.0, 0.1, to_obstacle, lanes)
        keep = set(orca_small.may_bind(z, vel, h, rows, v_want, steering, 0.25, 1.0, 0.1))
        for r in range(len(rows)):
            one = slice(r, r + 1)
            alone = avoid_reference(z, vel, h, rows[one], pref[one], v_want[one], steering, *args)
            assert (alone is not None) <= (r in keep)  # kept whenever the law steers it
            assert (r in keep) or alone is None
            skipped += r not in keep
            kept += alone is not None
    assert skipped > 50 and kept > 50


def test_avoid_small_hands_ties_to_the_law():
    """Robots on a circle and in a square grid: neighbours at the same distance, where Python's
    and numpy's rounding could order them differently, are left to ``avoid`` (``binding``
    returns None) and the commands stay the same bit for bit, with the lane half-planes
    too (narrow lanes that bind change the commands: the law is handed them)."""
    n = 8
    z = 2.0 * np.exp(2j * np.pi * np.arange(n) / n) + (3 + 3j)
    grid = (np.arange(9) % 3) + 1j * (np.arange(9) // 3) + (1 + 1j)

    def narrow(pts, idx):  # every robot in a lane along its heading, 0.02 m room each side
        return 1j * h[idx], np.full(len(idx), 0.02), np.full(len(idx), 0.02)

    for pts in (z, grid):
        m = len(pts)
        h = np.exp(1j * np.angle((3 + 3j) - pts))
        vel, rows = 0.8 * h, np.arange(m)
        steering = np.ones(m, dtype=bool)
        args = (pts, vel, h, rows, 0.9 * h, np.full(m, 0.9), steering, 0.25, 1.0, 0.1)
        assert orca_small.binding(*args[:4], *args[5:]) is None
        want = avoid_reference(*args, to_obstacle)
        assert want is not None
        assert same(orca_small.avoid_small(*args, to_obstacle), want)
        wall = lambda p: np.full(len(p), 0.5 + 0j)  # noqa: E731  an obstacle 0.5 m off
        laned = avoid_reference(*args, wall, narrow)
        assert not same(laned, avoid_reference(*args, wall))  # the lanes bind here
        assert same(orca_small.avoid_small(*args, wall, narrow), laned)


def test_the_bench_times_avoidance_inside_the_loop():
    """``mrta bench`` reports the cost of avoidance alone (``avoid_bare_ratio``, in bare
    ``space.step`` times) and of the site queues it brings (``sites_bare_ratio``) next to the
    whole loop's, from the same run."""
    from scenarios.bench.loop import bench_sim

    on = bench_sim(sizes=(10,), sim_seconds=20.0, avoidance="orca", control="array")["10"]
    off = bench_sim(sizes=(10,), sim_seconds=20.0, control="array")["10"]
    assert 0.0 < on["avoid_bare_ratio"] < on["bare_ratio"]
    assert 0.0 < on["avoid_share"] < 1.0
    assert off["avoid_bare_ratio"] == off["avoid_share"] == 0.0
    # site queues and service slots exist only with avoidance; their time is apart from it
    assert 0.0 < on["sites_share"] < 1.0 - on["avoid_share"]
    assert off["sites_bare_ratio"] == off["sites_share"] == 0.0
    # the parts of the control periods: the rules run only with avoidance
    assert on["parts_s"]["control"] > 0.0 and on["parts_s"]["traffic"] > 0.0
    assert on["parts_s"]["jams"] > 0.0 and on["parts_s"]["sites"] > 0.0
    assert off["parts_s"]["control"] > 0.0
    assert off["parts_s"]["traffic"] == off["parts_s"]["jams"] == off["parts_s"]["sites"] == 0.0
    assert sum(on["parts_s"].values()) < on["wall_s"]
    # the loop's own physics steps, timed apart from the control period's parts
    assert 0.0 < on["parts_s"]["physics"] and 0.0 < off["parts_s"]["physics"]
    assert on["physics_calib_ratio"] * on["calib_step_us"] * 1e-6 * on["sim_s"] * 60.0 == (
        pytest.approx(on["parts_s"]["physics"])
    )
    # the jam rule's re-plan, as the rule builds it and afresh, in the same run
    assert 0.0 < on["replan_ms"] and 0.0 < on["replan_fresh_ms"]
    assert "replan_ms" not in off


def test_the_small_team_path_reads_the_law_s_settings_where_the_law_does():
    """``[spatial.orca]``'s settings reach both paths of the law. The small-team path must read
    them where the law does: with fewer neighbours, a shorter horizon and a wider margin,
    ``avoid_small`` still gives ``avoid``'s commands bit for bit, and those differ from the
    defaults' on some scenes (a path that kept its own copy of ``max_neighbours`` would change
    only half the law)."""
    rng = np.random.default_rng(29)
    scenes = [scene(rng, 10) for _ in range(120)]

    def run_all(p):
        out = []
        for z, vel, h, rows, pref, v_want, steering, lanes in scenes:
            args = (z, vel, h, rows, pref, v_want, steering, 0.25, 1.0, 0.1, to_obstacle, lanes)
            law = orca.avoid(*args, p=p)
            assert same(orca_small.avoid_small(*args, p=p), law)
            out.append(law)
        return out

    default = run_all(DEFAULT)
    edited = run_all(orca.OrcaLaw.of(OrcaSpec(max_neighbours=3, tau_s=1.0, margin_m=0.08)))
    assert sum(not same(a, b) for a, b in zip(edited, default, strict=True)) > 10


def test_an_infeasible_program_takes_the_least_violating_velocity_of_the_whole_call():
    """Row 1 asks for u.x >= 0.5 and u.x <= -0.5: no velocity keeps both, and the least
    violating ones (0.5 m/s over) are those with u.x = 0. Its own candidates have one (its
    preferred velocity, 0.3 m/s north, and zero), but the law takes, as the enumeration over
    the whole call does, the first such candidate of the call's pool: row 0's preferred
    velocity, 0.7 m/s north. Row 0's program is feasible and keeps its own answer."""
    normal = np.array([[1.0 + 0j, -1.0 + 0j], [1.0 + 0j, -1.0 + 0j]])
    offset = np.array([[-_BIG, -_BIG], [0.5, 0.5]])
    pref = np.array([0.7j, 0.3j])
    want = solve_reference(normal, offset, pref, 1.0)
    assert want.tolist() == [0.7j, 0.7j]
    assert orca.solve(normal, offset, pref, 1.0).tolist() == want.tolist()
    tilted = np.exp(0.3j)  # the same with lines turned: violations then depend on both axes
    got = orca.solve(normal * tilted, offset, pref * tilted, 1.0)
    assert np.array_equal(got, solve_reference(normal * tilted, offset, pref * tilted, 1.0))
    assert got[1] == pytest.approx(0.7j * tilted)
