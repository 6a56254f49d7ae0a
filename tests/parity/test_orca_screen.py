"""The plain-Python first steps of the small-team ORCA path (``sim.spatial.control.orca_small``)
held to the law's own numbers, not only to its commands: ``half_plane_one`` is the law's half-plane
(``sim.spatial.law.orca.half_planes``) to rounding, in every one of its branches; ``binding`` finds
exactly the robots whose plan leaves one of their nearest robots' half-planes, with those
neighbours, and hands a scene to the law only where rounding could decide; ``may_bind`` keeps
exactly the robots with a half-plane their plan leaves.

``tests/parity/test_orca_fast.py`` holds the commands to the reference bit for bit; there, a screen
that kept too many robots, or a half-plane off by a factor that moved no decision in its scenes,
would pass: here it does not.
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.scenario import OrcaSpec
from sim.spatial.control import orca_small
from sim.spatial.law import orca
from sim.spatial.law.orca import half_planes, orca_range_m

# the settings' defaults (sim.scenario), under the names these tests use
MARGIN_M = OrcaSpec().margin_m
MAX_NEIGHBOURS = OrcaSpec().max_neighbours
TAU_S = OrcaSpec().tau_s
RADIUS, V_MAX, DT = 0.25, 1.0, 0.1
COMBINED = 2.0 * (RADIUS + MARGIN_M)


def branch(rel_p, rel_v):
    """Which part of the velocity obstacle's boundary is nearest: "inside" (the pair overlaps),
    "cutoff" (the truncating circle), "left" or "right" (a leg), computed independently of the
    code under test from the geometry of the cone."""
    dist = abs(rel_p)
    if dist <= COMBINED:
        return "inside"
    w = rel_v - rel_p / TAU_S
    dot1 = (w * rel_p.conjugate()).real
    if dot1 < 0.0 and dot1 * dot1 > COMBINED**2 * abs(w) ** 2:
        return "cutoff"
    return "left" if (rel_p.conjugate() * w).imag > 0.0 else "right"


def random_pairs(rng, n):
    rel_p = rng.uniform(0.1, 4.0, n) * np.exp(1j * rng.uniform(0, 2 * np.pi, n))
    rel_v = rng.uniform(0.0, 2.0, n) * np.exp(1j * rng.uniform(0, 2 * np.pi, n))
    vel_i = rng.uniform(0.0, 1.0, n) * np.exp(1j * rng.uniform(0, 2 * np.pi, n))
    share = np.where(rng.random(n) < 0.5, 0.5, 1.0)
    return rel_p, rel_v, vel_i, share


def test_half_plane_one_is_the_law_s_half_plane_in_every_branch():
    rng = np.random.default_rng(5)
    rel_p, rel_v, vel_i, share = random_pairs(rng, 4000)
    normal, offset = half_planes(rel_p, rel_v, vel_i, share, COMBINED, 1 / TAU_S, 1 / DT)
    seen = {"inside": 0, "cutoff": 0, "left": 0, "right": 0}
    tau = (1.0 / TAU_S, 1.0 / DT)
    for k in range(len(rel_p)):
        args = (complex(rel_p[k]), complex(rel_v[k]), complex(vel_i[k]), float(share[k]))
        n, c = orca_small.half_plane_one(*args, COMBINED, tau)
        assert abs(n - normal[k]) < 1e-12 and abs(c - offset[k]) < 1e-12, (k, n, c)
        assert abs(abs(n) - 1.0) < 1e-12  # a unit normal
        seen[branch(rel_p[k], rel_v[k])] += 1
    assert min(seen.values()) > 100, seen  # every branch was compared many times


def test_half_plane_one_geometry_by_hand():
    """Two cases worked by hand. Head-on at 2 m, closing at 2 m/s, reciprocal (share 0.5),
    i standing: the relative velocity lies on the cone's axis, so the nearest boundary is
    the right leg (the tie goes right): the normal is the leg's left-hand side. And a pair
    overlapping by 0.1 m at rest: the half-plane pushes i straight away at the cut-off
    circle's speed, half of (combined - distance) / dt."""
    n, c = orca_small.half_plane_one(2.0 + 0j, 2.0 + 0j, 0j, 0.5, COMBINED, (1 / TAU_S, 1 / DT))
    leg = np.sqrt(4.0 - COMBINED**2)
    direction = -(2.0 * complex(leg, -COMBINED)) / 4.0
    assert n == pytest.approx(1j * direction, abs=1e-15)
    u = (2.0 * direction.conjugate()).real * direction - 2.0
    assert c == pytest.approx((0.5 * u * n.conjugate()).real, abs=1e-15)
    n, c = orca_small.half_plane_one(0.5 + 0j, 0j, 0j, 0.5, COMBINED, (1 / TAU_S, 1 / DT))
    assert n == pytest.approx(-1.0, abs=1e-12)  # away from the neighbour at +x
    assert c == pytest.approx(0.5 * (COMBINED - 0.5) / DT, abs=1e-12)


def scene(rng, m, side):
    z = rng.uniform(0.3, side - 0.3, m) + 1j * rng.uniform(0.3, side - 0.3, m)
    h = np.exp(1j * rng.uniform(0, 2 * np.pi, m))
    vel = rng.uniform(0.0, 1.0, m) * h * np.exp(1j * rng.normal(0, 0.2, m))
    steering = rng.random(m) < 0.7
    steering[0] = True
    rows = steering.nonzero()[0]
    v_want = rng.uniform(-0.2, 1.0, len(rows))
    return z, vel, h, rows, v_want, steering


def law_margins(z, vel, h, rows, v_want, steering, nearest: bool):
    """For each robot of ``rows``: the largest amount by which its plan (``v_want`` along
    its heading) leaves a half-plane of a robot within range, over its ``MAX_NEIGHBOURS``
    nearest (``nearest``) or all of them, with those neighbours nearest first; from numpy."""
    reach = orca_range_m(RADIUS, V_MAX)
    out = []
    for row, j in enumerate(rows):
        d = np.abs(z - z[j])
        d[j] = np.inf
        near = np.argsort(d, kind="stable")
        near = near[d[near] < reach]
        if nearest:
            near = near[:MAX_NEIGHBOURS]
        if not len(near):
            out.append((-np.inf, []))
            continue
        share = np.where(steering[near], 0.5, 1.0)
        n, c = half_planes(
            z[near] - z[j], vel[j] - vel[near], vel[j], share, COMBINED, 1 / TAU_S, 1 / DT
        )
        plan = v_want[row] * h[j]
        out.append((float((c - (plan * n.conj()).real).max()), near.tolist()))
    return out


@pytest.mark.parametrize("m", [3, 10, 16])
def test_binding_finds_exactly_the_robots_whose_plan_leaves_a_half_plane(m):
    rng = np.random.default_rng(20 + m)
    decided = found_rows = 0
    for _ in range(150):
        z, vel, h, rows, v_want, steering = scene(rng, m, side=1.5 * m**0.5 + 1.0)
        found = orca_small.binding(z, vel, h, rows, v_want, steering, RADIUS, V_MAX, DT)
        if found is None:
            continue
        decided += 1
        want = [
            (row, near)
            for row, (worst, near) in enumerate(
                law_margins(z, vel, h, rows, v_want, steering, True)
            )
            if worst > 1e-9
        ]
        assert found == want
        found_rows += len(found)
    assert decided >= 135  # Python decides nearly every scene; the law only where rounding could
    assert found_rows > 100


def test_binding_hands_a_scene_to_the_law_only_where_rounding_could_decide():
    """Neighbours at the same distance, or one at the very edge of range, or a plan within
    1e-10 of the threshold: None (the law decides). A scene a hair away from each: decided."""
    reach = orca_range_m(RADIUS, V_MAX)
    steering = np.ones(3, dtype=bool)
    h = np.ones(3, dtype=complex)
    vel = np.zeros(3, dtype=complex)
    rows = np.arange(3)
    v_want = np.zeros(3)
    args = (rows, v_want, steering, RADIUS, V_MAX, DT)
    tie = np.array([0.0, 2.0, 2.0j])
    assert orca_small.binding(tie, vel, h, *args) is None
    assert orca_small.binding(tie * np.array([1, 1, 1.001]), vel, h, *args) is not None
    edge = np.array([0.0, reach, 10.0 + 10.0j])
    assert orca_small.binding(edge, vel, h, *args) is None
    assert orca_small.binding(edge * 1.001, vel, h, *args) is not None


@pytest.mark.parametrize("m", [3, 10, 16])
def test_may_bind_keeps_exactly_the_robots_whose_plan_leaves_a_half_plane(m):
    """The screen is conservative (every robot the law steers is kept: test_orca_fast.py) and
    tight: a robot kept has a half-plane of some robot within range that its plan leaves."""
    rng = np.random.default_rng(40 + m)
    kept = dropped = 0
    for _ in range(150):
        z, vel, h, rows, v_want, steering = scene(rng, m, side=1.5 * m**0.5 + 1.0)
        keep = orca_small.may_bind(z, vel, h, rows, v_want, steering, RADIUS, V_MAX, DT)
        margins = law_margins(z, vel, h, rows, v_want, steering, False)
        for row, (worst, _) in enumerate(margins):
            if abs(worst) < 1e-12:
                continue  # rounding decides
            assert (row in keep) == (worst > 0.0), (row, worst)
            kept += row in keep
            dropped += row not in keep
    assert kept > 100 and dropped > 100


def brute_neighbours(z, rows, range_m):
    """Each robot's ``MAX_NEIGHBOURS`` nearest others within ``range_m``, nearest first, in
    plain Python."""
    out = []
    for j in rows.tolist():
        near = sorted((abs(z[k] - z[j]), k) for k in range(len(z)) if k != j)
        out.append([k for d, k in near if d < range_m][:MAX_NEIGHBOURS])
    return out


@pytest.mark.parametrize("m", [5, 64, 65, 300])
def test_neighbour_table_is_the_nearest_robots_within_range_at_every_size(m):
    """Both ways of finding neighbours (a dense distance table up to 64 robots, a k-d tree
    above, as at fleet scale): each steering robot's ``MAX_NEIGHBOURS`` nearest within range,
    nearest first, and the mask marks exactly those; rows past them are masked out. Crowded
    enough that most robots have more than ``MAX_NEIGHBOURS`` in range, sparse enough that
    some have fewer, and some none."""
    rng = np.random.default_rng(m)
    reach = orca_range_m(RADIUS, V_MAX)
    side = 2.2 * m**0.5 + 2.0
    z = rng.uniform(0, side, m) + 1j * rng.uniform(0, side, m)
    z[-1] = -100.0  # a robot far from every other
    rows = np.sort(rng.choice(m, size=max(2, (2 * m) // 3), replace=False))
    rows[-1] = m - 1
    idx, mask = orca.neighbour_table(z, rows, reach)
    want = brute_neighbours(z, rows, reach)
    counts = [len(w) for w in want]
    assert idx.shape == mask.shape == (len(rows), min(MAX_NEIGHBOURS, m - 1))
    for r, near in enumerate(want):
        assert mask[r].sum() == len(near) and idx[r][mask[r]].tolist() == near, r
        assert mask[r, : len(near)].all()  # the real ones first
    assert 0 <= idx.min() and idx.max() < m
    assert counts[-1] == 0
    if m > MAX_NEIGHBOURS + 1:
        assert max(counts) == MAX_NEIGHBOURS and min(counts[:-1]) < MAX_NEIGHBOURS


def test_neighbour_table_is_none_when_no_robot_has_a_neighbour_in_range():
    reach = orca_range_m(RADIUS, V_MAX)
    for m in (3, 80):
        z = np.arange(m) * (reach + 0.1) + 0j
        assert orca.neighbour_table(z, np.arange(m), reach) is None
        z[1] = z[0] + reach - 0.1
        idx, mask = orca.neighbour_table(z, np.arange(m), reach)
        assert (
            mask.sum() == 2 and idx[0][mask[0]].tolist() == [1] and idx[1][mask[1]].tolist() == [0]
        )
    assert orca.neighbour_table(np.zeros(1, dtype=complex), np.arange(1), reach) is None
    assert orca.neighbour_table(np.zeros(4, dtype=complex), np.arange(0), reach) is None


@pytest.mark.parametrize("v_max", [1.0, 1.2])
def test_orca_range_is_where_a_head_on_pair_at_top_speed_starts_to_bind(v_max):
    """``orca_range_m`` is the centre distance within which two robots closing head on at the
    top speed each collide within the horizon: just inside it their half-planes bind (the
    law acts, at 3 m as at any distance below the range), just outside they do not, and
    nothing beyond it is looked at."""
    reach = orca_range_m(RADIUS, v_max)
    assert reach == pytest.approx(COMBINED + 2 * v_max * TAU_S)
    for d, binds in ((reach * (1 - 1e-6), True), (reach * (1 + 1e-6), False), (3.0, True)):
        n, c = half_planes(
            np.array([d + 0j]),
            np.array([2 * v_max + 0j]),
            np.array([v_max + 0j]),
            np.array([0.5]),
            COMBINED,
            1 / TAU_S,
            1 / DT,
        )
        assert (c[0] - (v_max * n[0].conjugate()).real > 1e-9) == binds, d
        z = np.array([0j, d + 0j])
        vel = np.array([v_max + 0j, -v_max + 0j])
        args = (z, vel, vel / v_max, np.arange(2), vel, np.full(2, v_max), np.ones(2, bool))
        out = orca.avoid(*args, RADIUS, v_max, DT, lambda p: np.full(len(p), np.inf + 0j))
        assert (out is not None) == binds, d
        if binds:
            assert out[0].tolist() == [0, 1] and (out[1] < v_max).all()


def test_forward_speed_honours_lines_that_ask_for_a_least_forward_speed():
    """A half-plane the heading crosses forwards (n . h > 0) bounds the forward speed from
    below, at c / (n . h): a robot with a robot closing from behind must keep going. Worked by
    hand: heading 60 degrees off the line's normal, c = 0.3: at least 0.6 m/s; with a second
    line capping it at 0.4 the program has no solution and the robot takes the middle, 0.5;
    a line the heading runs nearly along (3 degrees) asks for its least speed less the slack."""
    from sim.spatial.law.orca import forward_speed

    h = np.array([np.exp(1j * np.radians(60.0))])
    floor = np.array([[1.0 + 0j]]), np.array([[0.3]])
    assert forward_speed(*floor, h, np.array([0.1]), 1.0)[0] == pytest.approx(0.6)
    assert forward_speed(*floor, h, np.array([0.9]), 1.0)[0] == pytest.approx(0.9)
    both = np.array([[1.0 + 0j, -1.0 + 0j]]), np.array([[0.3, -0.2]])  # v >= 0.6, v <= 0.4
    assert forward_speed(*both, h, np.array([0.1]), 1.0)[0] == pytest.approx(0.5)
    shallow = np.array([np.exp(1j * np.radians(87.0))])  # n . h = sin 3 degrees
    a = np.cos(np.radians(87.0))
    floor = np.array([[1.0 + 0j]]), np.array([[0.01]])
    assert forward_speed(*floor, shallow, np.array([0.0]), 1.0)[0] == pytest.approx(0.01 / a)
    got = forward_speed(*floor, shallow, np.array([0.0]), 1.0, 0.005)[0]
    assert got == pytest.approx(0.005 / a)


def test_the_wall_screen_measures_the_way_moved_in_the_plane():
    """``near_walls`` keeps each robot's distance to the nearest obstacle with where it was
    measured, and passes a robot over while that distance less the way moved since stays
    beyond reach. The way moved is a distance in the plane: a robot measured 3 m from the
    wall at (0, 5) and now at (0.1, 0), 0.3 m from it, must be looked at again; one that
    moved 0.4 m along the wall is not (the screen asks for no distance: it saves the query)."""
    from sim.spatial.control.avoidance import near_walls

    class Follower:
        asked = 0

        def to_obstacle(self, pts):
            self.asked += len(pts)
            return np.where(pts.imag < 1.0, -0.3j, -3.0j) + 0 * pts  # a wall along y = -0.3

    fol = Follower()
    rows, v = np.array([0]), np.array([0.5])
    assert near_walls(fol, np.array([5.0j]), rows, v, RADIUS).tolist() == []  # 3 m away
    assert fol.asked == 1
    assert near_walls(fol, np.array([5.0j + 0.4]), rows, v, RADIUS).tolist() == []  # moved 0.4
    assert fol.asked == 1  # passed over without a look
    assert near_walls(fol, np.array([0.1 + 0j]), rows, v, RADIUS).tolist() == [0]
    assert fol.asked == 2


def test_the_wall_screen_drops_only_robots_whose_lines_cannot_bind():
    """``near_walls`` passes over robots far from every obstacle, using the distance it last
    measured less the way the robot moved since. Over 40 periods of 300 robots wandering among
    boxes, at random speeds, the commands from the screened robots equal, bit for bit, those
    from every robot, and the screen drops most of them."""
    from sim.spatial.control.avoidance import near_walls
    from sim.spatial.law.orca import steer_walls
    from sim.spatial.navigation.paths import PathFollower

    rng = np.random.default_rng(7)
    boxes = [
        ((x, y), (x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0))
        for x, y in [(3, 3), (12, 8), (6, 14)]
    ]
    fol = PathFollower(300, 1.5, boxes, 0.25)
    z = rng.uniform(0.5, 19.5, 300) + 1j * rng.uniform(0.5, 19.5, 300)
    rows = np.arange(300)
    dropped = 0
    for _ in range(40):
        z = z + (rng.normal(0.0, 0.1, 300) + 1j * rng.normal(0.0, 0.1, 300))
        h = np.exp(1j * rng.uniform(-np.pi, np.pi, 300))
        v = rng.uniform(-0.3, 1.5, 300)
        pref = 1.5 * np.exp(1j * rng.uniform(-np.pi, np.pi, 300))
        args = (0.25, 1.5, fol.to_obstacle)
        every = steer_walls(z, h, rows, v, pref, *args)
        kept = near_walls(fol, z, rows, v, 0.25)
        dropped += 300 - len(kept)
        screened = steer_walls(z, h, kept, v[kept], pref[kept], *args) if len(kept) else None
        if every is None:
            assert screened is None
        else:
            for a, b in zip(every, screened, strict=True):
                assert np.array_equal(a, b)
    assert dropped > 40 * 150
