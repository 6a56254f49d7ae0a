"""ORCA's small programs (``sim.spatial.law.orca``): ``solve`` against brute force, the
half-planes, the forward speed, the wall and robot programs and their slacks, the lane's
half-planes and the right-hand bias, on scenes set by hand. ORCA in whole runs is in
``tests/behaviour/test_orca.py``."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.scenario import OrcaSpec
from sim.spatial.law.orca import forward_speed, half_planes, solve

# the settings' defaults (sim.scenario), under the names these tests use
SLACK_SHALLOW = OrcaSpec().slack_shallow
MARGIN_M = OrcaSpec().margin_m
TAU_OBSTACLE_S = OrcaSpec().tau_obstacle_s
WALL_GAP_M = OrcaSpec().wall_gap_m
WALL_SLACK_MPS = OrcaSpec().wall_slack_mps


def brute_force(normal, offset, pref, v_max, step=0.01):
    """Nearest feasible velocity to pref on a grid over the speed disc (None if none)."""
    g = np.arange(-v_max, v_max + step / 2, step)
    u = (g[:, None] + 1j * g[None, :]).ravel()
    u = u[np.abs(u) <= v_max]
    ok = ((u[:, None] * normal.conj()).real >= offset - 1e-12).all(axis=1)
    if not ok.any():
        return None
    return u[ok][np.abs(u[ok] - pref).argmin()]


def test_solve_matches_brute_force_on_random_programs():
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(200):
        lines = int(rng.integers(1, 5))
        normal = np.exp(1j * rng.uniform(0, 2 * math.pi, lines))
        offset = rng.uniform(-1.0, 0.6, lines)
        pref = complex(*rng.uniform(-1.5, 1.5, 2))
        want = brute_force(normal, offset, pref, 1.0)
        got = solve(normal[None], offset[None], np.array([pref]), 1.0)[0]
        if want is None:
            continue
        checked += 1
        assert abs(got) <= 1.0 + 1e-9
        assert ((got * normal.conj()).real >= offset - 1e-9).all()
        assert abs(got - pref) <= abs(want - pref) + 1e-9  # at least as near as the grid's best
    assert checked > 100


def test_half_plane_of_a_head_on_pair_asks_each_for_half_and_lets_sideways_through():
    """Two robots 2 m apart closing at 1 m/s each (horizon 1.5 s, radii 0.3 m): the relative
    velocity 2 m/s enters the cone, so each must give up some closing speed, while moving away
    or to the side stays allowed."""
    n, c = half_planes(
        np.array([2.0 + 0j]),
        np.array([2.0 + 0j]),
        np.array([1.0 + 0j]),
        np.array([0.5]),
        0.6,
        1 / 1.5,
        10.0,
    )
    allowed = lambda u: (u * n.conj()).real[0] >= c[0] - 1e-12  # noqa: E731
    assert not allowed(1.0 + 0j)
    assert allowed(-0.5 + 0j)
    assert allowed(0.2 + 1j) or allowed(0.2 - 1j)


def test_forward_speed_keeps_the_driven_velocity_in_every_half_plane():
    """Exactly without slack; with ``slack``, a line the heading runs nearly along (``|n . h|``
    below ``SLACK_SHALLOW``) may be closed on at that speed and no faster; a line it crosses
    more steeply, not at all."""

    normal = np.array([[-1.0 + 0j, 1j]])  # u.x <= 0.4, u.y >= -0.2
    offset = np.array([[-0.4, -0.2]])
    v = forward_speed(normal, offset, np.array([1.0 + 0j]), np.array([1.5]), 1.5)
    assert v[0] == pytest.approx(0.4)
    v = forward_speed(normal, offset, np.array([1.0 + 0j]), np.array([1.5]), 1.5, 0.005)
    assert v[0] == pytest.approx(0.4)  # the heading crosses the binding line head on
    wall = np.array([[-1j]]), np.array([[0.0]])  # a wall above, the robot on its line
    for deg, slack in [(30.0, 0.0), (30.0, 0.005), (3.0, 0.0)]:
        into = np.array([np.exp(1j * np.radians(deg))])
        assert forward_speed(*wall, into, np.array([1.0]), 1.5, slack)[0] == 0.0
    into = np.array([np.exp(1j * np.radians(3.0))])
    assert into[0].imag < SLACK_SHALLOW
    v = forward_speed(*wall, into, np.array([1.0]), 1.5, 0.005)
    assert v[0] * into[0].imag == pytest.approx(0.005)


def test_the_robot_program_never_backs_a_robot_up():
    """A robot squeezed in a crowd had a forward program with no solution, and the middle of
    what its lines left was backwards, into the robot behind it (the 20-robot circle swap). On
    random programs the forward speed is never negative; where the lines would have the
    robot back away (a robot closing from in front) it stops."""
    rng = np.random.default_rng(3)
    n, k = 2000, 6
    normal = np.exp(1j * rng.uniform(-np.pi, np.pi, (n, k)))
    offset = rng.uniform(-1.0, 0.5, (n, k))
    h = np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    v = forward_speed(normal, offset, h, rng.uniform(0.0, 1.5, n), 1.5)
    assert np.all(v >= 0.0)
    ahead = np.array([[-1.0 + 0j]]), np.array([[0.3]])  # wants u.x <= -0.3: back away
    assert forward_speed(*ahead, np.array([1.0 + 0j]), np.array([1.0]), 1.5)[0] == 0.0


def test_a_robot_frozen_on_a_line_is_released_by_the_slack():
    """The freeze seen in the warehouse (market, seed 6, robot 4 stood 24 s by a shelf until
    its task failed): a robot exactly on the line of a wall above it (offset 0), heading west
    2e-4 rad into the wall, preferring west and a little into the wall, takes u along the
    wall. Held exactly (both slacks 0) the forward program gives it no speed, and its turn,
    proportional to 2e-4 rad, never brings the heading across. With the slacks (the law's
    defaults) it drives along the wall (the wall program, ``wall_slack_mps``) and along a
    robot's line (the robot program, ``robot_slack_mps``), each setting for its own lines."""
    from sim.spatial.law import orca

    radius = 0.25
    on_line = radius + MARGIN_M + WALL_GAP_M
    law = orca.DEFAULT
    wall = lambda pts: np.full(len(pts), 1j * on_line)  # noqa: E731
    far = lambda pts: np.full(len(pts), np.inf + 0j)  # noqa: E731
    h = np.array([np.exp(1j * (np.pi - 2e-4))])  # west, a hair north (into the line)
    pref, rows, z = np.array([-1.5 + 0.5j]), np.array([0]), np.array([0j])

    def walls(p):
        out = orca.steer_walls(z, h, rows, np.array([1.0]), pref, radius, 1.5, wall, p=p)
        return out[1][0]

    def robots(p):  # a robot line in place of the wall's, no obstacle near
        n, c = np.array([[-1j]]), np.array([[0.0]])
        return orca.steer_rows(z, h, rows, n, c, pref, radius, 1.5, far, p=p)[1][0]

    assert law.wall_slack_mps == law.robot_slack_mps == 0.005
    assert walls(law) == 1.0  # drives along the wall at its plan's speed
    assert robots(law) > 1.0
    no_wall_slack = orca.OrcaLaw.of(OrcaSpec(wall_slack_mps=0.0))
    assert walls(no_wall_slack) == 0.0  # frozen
    assert robots(no_wall_slack) > 1.0
    neither = orca.OrcaLaw.of(OrcaSpec(wall_slack_mps=0.0, robot_slack_mps=0.0))
    assert robots(neither) == 0.0  # frozen


def test_in_a_narrow_lane_orca_keeps_the_velocity_inside_the_free_width(monkeypatch):
    """Robot 0 drives +x in a lane with 0.06 m of room to its right; robot 1 comes head-on a
    little to its left, so ORCA (with the right-hand preference) would step right. With the
    lane's half-planes the chosen velocity moves right at most (0.06 - LANE_AIR_M) /
    TAU_OBSTACLE_S; without them, in a lane wider than LANE_NARROW_M or with no wall within
    LANE_NEAR_M of the body, they do not apply."""
    from sim.spatial.law import orca

    got = []
    inner = orca.solve
    monkeypatch.setattr(orca, "solve", lambda *a: got.append(inner(*a)) or got[-1])
    z = np.array([0.0 + 0.0j, 1.2 + 0.1j])
    vel = np.array([1.0 + 0j, -1.0 + 0j])
    h = np.array([1.0 + 0j, -1.0 + 0j])
    rows = np.array([0])
    near = lambda pts: np.full(len(pts), -0.6j)  # noqa: E731  a wall 0.35 m right of the body
    args = (z, vel, h, rows, np.array([1.0 + 0j]), np.array([1.0]), np.array([True, True]))
    args += (0.25, 1.0, 0.1, near)

    def lanes(room_right, room_left=0.3):
        return lambda pts, idx: (np.array([1j]), np.array([room_left]), np.array([room_right]))

    orca.avoid(*args)
    free = got[-1][0]
    orca.avoid(*args, lanes(0.06))
    laned = got[-1][0]
    orca.avoid(*args, lanes(1.0, 1.0))  # 2 m of free width: not a narrow lane
    wide = got[-1][0]
    far = lambda pts: np.full(len(pts), 50.0 + 0j)  # noqa: E731
    orca.avoid(*args[:-1], far, lanes(0.06))  # no wall near: past the narrow part
    past = got[-1][0]
    orca.avoid(*args[:-1], far)
    assert past == got[-1][0]
    bound = (0.06 - OrcaSpec().lane_air_m) / TAU_OBSTACLE_S
    assert -free.imag > bound  # without the lane ORCA steps right ...
    assert -laned.imag <= bound + 1e-9  # ... with it, no faster than the room allows
    assert wide == free


def test_walls_as_orca_lines_let_a_robot_slide_along_a_wall_but_not_close_on_it():
    """A robot 0.32 m from a wall (0.02 m beyond the line at ``radius + MARGIN_M``) heads 30
    degrees into it at 1 m/s: its line binds, the forward speed it gets keeps the driven
    velocity in the half-plane, less ``WALL_SLACK_MPS`` (the wall program never backs) and it turns
    toward the velocity nearest its preferred one, along the wall, away from it. Heading along
    the wall at 0.5 m from it, nothing binds: None (its plan stays)."""
    from sim.spatial.law.orca import steer_walls

    radius, dist = 0.25, 0.32
    wall = lambda pts: np.full(len(pts), -1j * dist)  # noqa: E731  a wall below each robot
    h = np.array([np.exp(-1j * math.radians(30.0))])
    pref = np.array([1.0 + 0j])
    rows = np.array([0])
    out = steer_walls(np.array([0j]), h, rows, np.array([1.0]), pref, radius, 1.5, wall)
    assert out is not None
    sel, v, w = out
    assert sel.tolist() == [0]
    closing = -(v[0] * h[0]).imag  # toward the wall
    allowed = (dist - radius - MARGIN_M - WALL_GAP_M) / TAU_OBSTACLE_S + WALL_SLACK_MPS
    assert closing <= allowed + 1e-12
    assert 0.0 <= v[0] <= 1.0
    assert w[0] > 0.0  # turns left, away from the wall below
    far = lambda pts: np.full(len(pts), -0.5j)  # noqa: E731
    flat = np.array([1.0 + 0j])
    assert steer_walls(np.array([0j]), flat, rows, np.array([1.0]), pref, radius, 1.5, far) is None


def test_the_right_hand_bias_holds_only_where_the_body_has_room_to_the_nearest_obstacle():
    """A robot at the origin heading east whose one robot half-plane lets it no faster than
    0.2 m/s east (u.x <= 0.2) prefers 1 m/s east. By default the preference is turned
    ``right_bias_deg`` right however near an obstacle (one above it), so the velocity it takes
    points right of its heading and it turns right. With ``bias_room_m`` = 1 m only where the
    body has more room than that; with less it keeps its
    heading (the velocity nearest 1 m/s east is 0.2 m/s east). Both sides of the threshold."""
    from sim.spatial.law import orca

    radius = 0.25
    normal, offset = np.array([[-1.0 + 0j]]), np.array([[-0.2]])
    rows, z, h = np.array([0]), np.array([0j]), np.array([1.0 + 0j])
    pref = np.array([1.0 + 0j])

    def turn(room, p=orca.DEFAULT):
        above = lambda pts: np.full(len(pts), 1j * (radius + room))  # noqa: E731
        if room == math.inf:  # what the path follower gives with no obstacle at all
            above = lambda pts: np.full(len(pts), np.inf + 0j)  # noqa: E731
        out = orca.steer_rows(z, h, rows, normal, offset, pref, radius, 1.5, above, p=p)
        return out[2][0]

    assert orca.DEFAULT.bias_room_m == -math.inf  # bias_room_m = 0: no limit
    assert turn(0.05) < -0.1 and turn(3.0) < -0.1 and turn(math.inf) < -0.1
    metre = orca.OrcaLaw.of(OrcaSpec(bias_room_m=1.0))
    assert turn(1.05, metre) < -0.1  # room: turned right
    assert turn(0.95, metre) == 0.0  # beside an obstacle: straight on
    assert turn(math.inf, metre) < -0.1  # no obstacle at all


def test_the_bias_in_meetings_turns_a_head_on_or_stood_robot_and_no_other():
    """With ``bias_meet_deg`` = 30 a robot at the origin preferring 1 m/s east takes the bias
    when a neighbour lies within 30 degrees of its preferred velocity relative to that
    neighbour's velocity: one 1 m east coming west (head on), or standing 1 m away at 29
    degrees; not one at 31 degrees, one beside it, or one ahead driving east as fast (nothing
    to meet: the relative velocity is zero). A robot ``stood`` takes it whatever its neighbours
    do. With 180 the rule is off (None: every robot). Then the commands: the
    robot allowed the bias turns right, the one not allowed keeps its heading."""
    from sim.spatial.law import orca

    p = orca.OrcaLaw.of(OrcaSpec(bias_meet_deg=30.0, bias_stand_s=1.0))
    everywhere = orca.OrcaLaw.of(OrcaSpec(bias_meet_deg=180.0))
    assert p.meet_all is False and everywhere.meet_all is True
    deg = np.radians
    others = [  # (position, velocity) of the one neighbour, and whether it is a meeting
        (1.0 + 0j, -0.5 + 0j, True),
        (np.exp(1j * deg(29.0)), 0j, True),
        (np.exp(-1j * deg(29.0)), 0j, True),
        (np.exp(1j * deg(31.0)), 0j, False),
        (1j, 0j, False),
        (1.0 + 0j, 1.0 + 0j, False),
        (-1.0 + 0j, 0j, False),  # behind
    ]
    z = np.array([0j] + [o[0] for o in others])
    vel = np.array([0j] + [o[1] for o in others])
    n = len(others)
    rows = np.zeros(n, dtype=int)  # robot 0 once against each neighbour alone
    idx, mask = np.arange(1, n + 1)[:, None], np.ones((n, 1), dtype=bool)
    pref = np.full(n, 1.0 + 0j)
    allow = orca.meeting(z, vel, rows, idx, mask, pref, None, p)
    assert allow.tolist() == [o[2] for o in others]
    stood = np.zeros(n + 1, dtype=bool)
    stood[0] = True
    assert orca.meeting(z, vel, rows, idx, mask, pref, stood, p).all()
    assert not orca.meeting(z, vel, rows, idx, ~mask, pref, None, p).any()  # no real neighbour
    assert orca.meeting(z, vel, rows, idx, mask, pref, stood, everywhere) is None

    normal, offset = np.array([[-1.0 + 0j]]), np.array([[-0.2]])  # u.x <= 0.2
    one, h = np.array([0]), np.array([1.0 + 0j])
    free = lambda pts: np.full(len(pts), np.inf + 0j)  # noqa: E731
    args = (np.array([0j]), h, one, normal, offset, np.array([1.0 + 0j]), 0.25, 1.5, free)
    turned = orca.steer_rows(*args, p=p, allow=np.array([True]))[2][0]
    straight = orca.steer_rows(*args, p=p, allow=np.array([False]))[2][0]
    assert turned < -0.1 and straight == 0.0


def test_the_wall_program_never_backs_a_robot_up():
    """The wall program has no robot half-planes, so it must not reverse: a robot backing off
    a wall drove into the robot behind it (the robot-robot impacts of paper_spatial, robots
    backing at 0.45 m/s). Robots 0.26 to 0.6 m from a wall (inside its line and beyond it),
    facing it at every angle from head-on to along it, planning 0.2 to 1.5 m/s: every speed
    the program sets is >= 0, and where the robot is inside the line (the line wants it to move
    away) it stops and turns away from the wall."""
    from sim.spatial.law.orca import steer_walls

    radius = 0.25
    dists = np.linspace(0.26, 0.6, 9)
    angles = np.radians(np.linspace(-90.0, 0.0, 10))  # -90: straight at the wall below
    d, a = (x.ravel() for x in np.meshgrid(dists, angles))
    n = len(d)
    z = np.arange(n) * 10.0 + 0j  # far apart: one wall point below each
    wall = lambda pts: -1j * d[np.round(pts.real / 10.0).astype(int)] + 0j  # noqa: E731
    h = np.exp(1j * a)
    for speed in (0.2, 0.8, 1.5):
        out = steer_walls(
            z, h, np.arange(n), np.full(n, speed), np.full(n, 1.0 + 0j), radius, 1.5, wall
        )
        assert out is not None
        sel, v, w = out
        assert np.all(v >= 0.0)
        inside = d[sel] < radius + MARGIN_M
        into = np.sin(a[sel]) < -0.5  # facing the wall more than 30 degrees
        stop = inside & into
        assert stop.any() and np.all(v[stop] == 0.0)
        assert np.all(w[stop] > 0.0)  # turning left, away from the wall below
