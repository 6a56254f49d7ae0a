"""Reciprocal velocity-level collision avoidance (ORCA) for differential-drive robots.

ORCA (van den Berg, Guy, Lin, Manocha, "Reciprocal n-body collision avoidance", 2011): every
neighbour k of robot i gives one half-plane of velocities, ORCA_ik, that keeps the pair apart for
the time horizon ``tau`` if both take their share of the avoidance (half for a robot that steers
itself, all of it for one that stands); the nearest obstacle point gives one more (horizon
``tau_obstacle``). The robot takes the velocity u nearest its preferred velocity inside every
half-plane and the speed disc; when there is none, the one that violates the half-planes least.

Differential drive cannot take any velocity at once. It turns toward u and drives along its
heading h only at a speed v whose velocity v h itself lies in every half-plane (a second,
one-dimensional program along h): the velocity it really drives is always an ORCA velocity
(to within the slack below), so the reciprocal guarantee holds for what the wheels do, not
only for the holonomic u it aims at.
This replaces Alonso-Mora et al.'s (2010) tracking-error bound by an exact constraint; the
radius is still enlarged by ``margin_m`` for the one control period a command is held while the
robot turns (an arc, not the straight line ORCA assumes).
Held exactly, the one-dimensional program can freeze a robot: on a line (offset 0), heading a
hair into it while u runs along it, it gets no forward speed, and its turn toward u,
proportional to that hair, brings the heading ever nearer u but never across (the warehouse,
market, seed 6: a robot stood 24 s on a shelf's line until its task failed). So a line the
heading runs nearly along (``|n . h|`` below ``slack_shallow``, about 5.7 degrees) may be closed
on at ``robot_slack_mps`` (robots' lines) or ``wall_slack_mps`` (walls' and lanes'): at most 0.5
mm a control period, and only by a robot driving almost parallel to the line.
A slack on every line was tried: it gave a contact in the 20-robot circle swap.

Walls: a robot that no robot half-plane binds still has the obstacle lines (the nearest
obstacle point, and the two sides of a single lane): where its plan leaves one of them,
:func:`steer_walls` gives it the same two programs over those lines alone, so it slides along a
wall instead of creeping into it (the law without avoidance lets a robot close on a wall at
``creep_mps``, and the warehouse's robots touched its shelves about three times an hour each).

Symmetry: when many preferred velocities point at one spot (robots swapping places on a
circle) plain ORCA slows them all to a standstill there. A robot whose plan leaves a half-plane
prefers its velocity turned ``right_bias_deg`` to the right, a right-hand traffic rule that makes
every pair pass the same way round, so the crowd turns as a roundabout instead of jamming
(``tests/behaviour/test_orca.py``: 20 robots swap a 5 m circle in 16.7 s, 17.8 s with the
compiled period, IR-SIM RVO 23.1 s, without a contact).
``bias_room_m`` limits it to robots whose body has more room than that to the nearest obstacle;
the default, ``-inf``, biases every such robot. 1.0 m was measured: faster in both scenarios,
but head-on pairs in the warehouse's 2 m aisles, which then no longer agree on a side, lost
tasks to jams.
``bias_meet_deg`` (30 by default; 180: off) limits it to meetings (:func:`meeting`): a robot
whose preferred velocity, relative to a neighbour's velocity, points within that angle of the
neighbour (a head-on or near-symmetric approach, where the two must agree on a side), or one
that has made no progress for ``bias_stand_s`` (the stuck clock: a knot to be untied). A robot
following another or crossing behind it keeps its line: in the warehouse 0.4 % more tasks than
the bias everywhere, and the circle swaps, sites and junction are as fast or faster
(``docs/results/avoidance.md``).

Walls from every edge: with ``wall_lines`` above 1 (4 by default) a robot gets a line from the
nearest point of each obstacle edge in reach, not only from the nearest obstacle point
(``PathFollower.obstacle_points``: points on or behind a nearer one's line left out), so in a
gap or an inside corner it sees both walls. In the warehouse it halves the robot-wall contacts
and allocates 0.5 % more tasks; on the depot map it keeps robots off walls the bias in
meetings alone touched (``docs/results/avoidance.md``).

Crowds: a robot's program has the lines of its ``max_neighbours`` nearest robots, 10 as in
RVO2's examples, and never backs it up (``back_share``, as the wall program since commit
aad4a41). In the 20-robot circle swap (starts moved by 0.1 mm, seed 1) robots in a knot with
9-11 others within 1.2 m had forward programs with no solution for most of a second, and the
middle of what their lines left drove one backwards at 0.3 of the top speed and the robot
behind it forwards, into each other. With 6 neighbours and backing at up to 0.3 of
the top speed, 13 of 29 swaps from starts moved by about 0.1 mm touched (``mrta hardcase circle
--jitter 1e-4 --seeds 29``; docs/results/avoidance.md); with 10 and none, none.

The programs are small (at most ``max_neighbours`` + 3 lines) and solved for every robot at once:
the optimum of a convex quadratic over half-planes and a disc is the preferred velocity, its
projection on one line, the crossing of two lines or a point where a line meets the circle.
:func:`solve` tries the first two kinds and enumerates every candidate (:func:`solve_enumerated`)
only for the robots left over. One module, one law, called by both control periods
(``sim.spatial.control``) on the robots near others only; for a small team
(``sim.spatial.control.orca_small.avoid_small``) the neighbours and the test whether a plan leaves a
half-plane run in plain Python first, and the commands come from the same numpy code, bit for
bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from sim.scenario import LawSpec, OrcaSpec


@dataclass(frozen=True, slots=True)
class OrcaLaw:
    """ORCA's settings as the functions below read them: ``[spatial.orca]`` (:class:`OrcaSpec`,
    where each is explained) and the steering of ``[spatial.law]`` (heading gain, the cosine
    of the turn-in-place angle). Build it with :meth:`of`."""

    tau_s: float
    tau_obstacle_s: float
    margin_m: float
    wall_gap_m: float
    lane_air_m: float
    lane_narrow_m: float
    lane_near_m: float
    max_neighbours: int
    wall_lines: int  # obstacle lines per robot (1: the nearest obstacle point only)
    back_share: float
    robot_slack_mps: float
    wall_slack_mps: float
    slack_shallow: float
    keep_right: complex  # the right-hand bias as a unit complex factor
    bias_room_m: float  # the bias only where the body has more room than this (-inf: anywhere)
    meet_all: bool  # the bias for every robot (``bias_meet_deg`` 180), else only in a meeting
    cos_meet: float  # cos(bias_meet_deg)
    bias_stand_s: float  # ... or after this long without progress
    heading_gain: float
    cos_turn: float

    @classmethod
    def of(cls, orca: OrcaSpec | None = None, law: LawSpec | None = None) -> OrcaLaw:
        """The law of a scenario's ``[spatial.orca]`` and ``[spatial.law]`` (defaults: the
        bundled scenarios')."""
        o = OrcaSpec() if orca is None else orca
        lw = LawSpec() if law is None else law
        return cls(
            tau_s=o.tau_s,
            tau_obstacle_s=o.tau_obstacle_s,
            margin_m=o.margin_m,
            wall_gap_m=o.wall_gap_m,
            lane_air_m=o.lane_air_m,
            lane_narrow_m=o.lane_narrow_m,
            lane_near_m=o.lane_near_m,
            max_neighbours=o.max_neighbours,
            wall_lines=o.wall_lines,
            back_share=o.back_share,
            robot_slack_mps=o.robot_slack_mps,
            wall_slack_mps=o.wall_slack_mps,
            slack_shallow=o.slack_shallow,
            keep_right=np.exp(-1j * np.radians(o.right_bias_deg)),
            bias_room_m=o.bias_room_m if o.bias_room_m > 0.0 else -np.inf,
            meet_all=o.bias_meet_deg >= 180.0,
            cos_meet=math.cos(math.radians(o.bias_meet_deg)),
            bias_stand_s=o.bias_stand_s,
            heading_gain=lw.heading_gain,
            cos_turn=math.cos(lw.turn_in_place_rad),
        )


_BIG = 1e9
DEFAULT = OrcaLaw.of()  # the bundled scenarios' law (immutable)


def orca_range_m(radius_m: float, v_max_mps: float, p: OrcaLaw = DEFAULT) -> float:
    """Centre distance beyond which no half-plane can bind within ``tau_s``: two robots closing
    at twice the top speed for the horizon, plus their radii, m."""
    return 2.0 * (radius_m + p.margin_m) + 2.0 * v_max_mps * p.tau_s


def neighbour_table(z: np.ndarray, rows: np.ndarray, range_m: float, max_neighbours: int = 10):
    """The nearest ``max_neighbours`` robots of each robot ``rows`` within ``range_m``.

    Args:
        z: (m,) positions x + iy, m; rows: (n,) the robots that steer.

    Returns:
        (n, K) neighbour indices and a (n, K) mask of the real ones (K <= ``max_neighbours``),
        or None when no robot of ``rows`` has a neighbour within range.
    """
    m = len(z)
    k = min(max_neighbours, m - 1)
    if k < 1 or not len(rows):
        return None
    if m <= 64:
        dist = np.abs(z[rows, None] - z[None, :])
        dist[np.arange(len(rows)), rows] = np.inf
        idx = np.argsort(dist, axis=1, kind="stable")[:, :k]
        near = np.take_along_axis(dist, idx, axis=1)
    else:
        xy = np.column_stack([z.real, z.imag])
        near, idx = cKDTree(xy).query(xy[rows], k=k + 1, distance_upper_bound=range_m)
        near, idx = near[:, 1:], idx[:, 1:]  # the first is the robot itself
        idx = np.where(idx >= m, 0, idx)
    mask = near < range_m
    if not mask.any():
        return None
    return idx, mask


def half_planes(rel_p, rel_v, vel_i, share, combined_m, inv_tau, inv_dt):
    """ORCA half-planes {u : Re(conj(n) u) >= c} of robot i against its neighbours.

    Args:
        rel_p: (..,) neighbour position minus i's, m (complex).
        rel_v: (..,) i's velocity minus the neighbour's, m/s (complex).
        vel_i: (..,) i's velocity, m/s.
        share: (..,) i's share of the avoidance (0.5 reciprocal, 1 against a standing robot).
        combined_m: sum of the two radii, m; inv_tau: 1 / horizon; inv_dt: 1 / control period.

    Returns:
        Unit normals n (complex) and offsets c: the velocities u with n . u >= c are allowed.
    """
    dist2 = (rel_p * rel_p.conj()).real
    r2 = combined_m * combined_m
    w = rel_v - rel_p * inv_tau  # from the centre of the cut-off circle to the relative velocity
    w2 = (w * w.conj()).real
    dot1 = (w * rel_p.conj()).real
    apart = dist2 > r2
    cutoff = apart & (dot1 < 0.0) & (dot1 * dot1 > r2 * w2)
    # inside a collision: the cut-off circle of the control period instead of the horizon
    w = np.where(apart, w, rel_v - rel_p * inv_dt)
    w2 = (w * w.conj()).real
    w_len = np.sqrt(np.maximum(w2, 1e-18))
    unit_w = w / w_len
    circ_u = (combined_m * np.where(apart, inv_tau, inv_dt) - w_len) * unit_w
    circ_dir = -1j * unit_w
    # the legs of the cone: left when the relative velocity passes on the left of rel_p
    leg = np.sqrt(np.maximum(dist2 - r2, 0.0))
    left = (rel_p.conj() * w).imag > 0.0
    safe2 = np.maximum(dist2, 1e-18)
    dir_left = rel_p * (leg + 1j * combined_m) / safe2
    dir_right = -(rel_p * (leg - 1j * combined_m)) / safe2
    leg_dir = np.where(left, dir_left, dir_right)
    leg_u = (rel_v * leg_dir.conj()).real * leg_dir - rel_v
    use_circle = cutoff | ~apart
    direction = np.where(use_circle, circ_dir, leg_dir)
    u = np.where(use_circle, circ_u, leg_u)
    point = vel_i + share * u
    normal = 1j * direction  # allowed side: left of the direction
    return normal, (point * normal.conj()).real


def obstacle_plane(to_obstacle, radius_m: float, inv_tau: float):
    """Half-plane of velocities that keep a robot of ``radius_m`` off the obstacle point
    ``to_obstacle`` (x + iy from its centre) for ``1 / inv_tau`` s: the normal points away."""
    dist = np.abs(to_obstacle)
    finite = np.isfinite(dist)
    safe = np.where(finite, to_obstacle, 0.0)  # no obstacle at all: inf, masked below
    normal = np.where(finite, -safe / np.maximum(dist, 1e-12), 1.0)
    offset = np.where(finite, -(dist - radius_m) * inv_tau, -_BIG)
    return normal, offset


def solve(normal: np.ndarray, offset: np.ndarray, pref: np.ndarray, v_max: float) -> np.ndarray:
    """Velocity nearest ``pref`` with |u| <= ``v_max`` and n . u >= c for every line, per row;
    where no velocity satisfies every line, the candidate that violates them least.

    The nearest point is unique, so most rows are done before the full enumeration
    (:func:`solve_enumerated`, which picks the same point): ``pref`` on the speed disc, if it
    keeps every line; else, for each line j that point breaks, the point of line j inside the
    disc nearest ``pref`` is the nearest point of half-plane j and the disc, so if it keeps
    every line it is the answer. Only the rows left over are enumerated.

    Args:
        normal, offset: (n, L) unit normals and offsets (unused lines: offset -inf or large
            negative); pref: (n,) preferred velocities.
    """
    u = pref * np.minimum(1.0, v_max / np.maximum(np.abs(pref), 1e-12))
    broken = offset - (u[:, None] * normal.conj()).real > 1e-9  # (n, L)
    left = broken.any(axis=1).nonzero()[0]
    if not len(left):
        return u
    n, c, p, broken = normal[left], offset[left], pref[left], broken[left]
    q = p[:, None] + (c - (p[:, None] * n.conj()).real) * n  # projections on the lines
    half = np.sqrt(np.maximum(v_max * v_max - c * c, 0.0))
    foot = c * n
    plus, minus = foot + half * 1j * n, foot - half * 1j * n  # where the lines meet the circle
    lim = v_max * (1.0 + 1e-9)
    nearer = np.abs(plus - p[:, None]) <= np.abs(minus - p[:, None])
    q = np.where(np.abs(q) > lim, np.where(nearer, plus, minus), q)  # ... or the chord's end
    viol = (c[:, None, :] - (q[:, :, None] * n[:, None, :].conj()).real).max(axis=2)
    ok = broken & (viol <= 1e-9) & (np.abs(q) <= lim)
    found = ok.any(axis=1)
    score = np.where(ok[found], np.abs(q[found] - p[found, None]), np.inf)
    u[left[found]] = q[found, score.argmin(axis=1)]
    rest = left[~found]
    if len(rest):  # each on its own candidates; the call's pool only where none is feasible
        n, c, p = normal[rest], offset[rest], pref[rest]
        u[rest] = got = solve_enumerated(n, c, p, v_max, pool=p[:, None])
        viol = (c - (got[:, None] * n.conj()).real).max(axis=1)
        none = (viol > 1e-9) | (np.abs(got) > v_max * (1.0 + 1e-9))
        if none.any():
            u[rest[none]] = solve_enumerated(n[none], c[none], p[none], v_max, pool=pref)
    return u


def solve_enumerated(
    normal: np.ndarray,
    offset: np.ndarray,
    pref: np.ndarray,
    v_max: float,
    pool=None,
    cells: int = 1 << 22,
) -> np.ndarray:
    """:func:`solve` by enumeration: every candidate (``pref`` on the speed disc, its
    projection on each line, the points where a line meets the circle, the crossings of two
    lines, zero) checked against every line; the nearest feasible one, or where there is none
    the one that violates the lines least.

    The first candidates of each row are every velocity of ``pool`` (default ``pref``: every
    row's) scaled as that row's own: so the law has always been computed (``pref`` times a
    column), and where a row's program is infeasible the least violating candidate can be
    another robot's preferred velocity. Where it is feasible this changes nothing.

    Args:
        normal, offset: (n, L) unit normals and offsets (unused lines: offset -inf or large
            negative); pref: (n,) preferred velocities; pool: (P,) the other rows' ones, or
            (n, 1) for each row its own only.
        cells: the most (row, candidate, line) values built at once (default 4M complex
            values, 64 MB); larger programs go in row blocks, which give the same rows bit
            for bit.
    """
    pool = pref if pool is None else pool
    lines = normal.shape[1]
    width = pool.shape[-1] + 3 * lines + lines * (lines - 1) // 2 + 1  # candidates per row
    block = max(1, cells // max(1, width * lines))
    if len(pref) <= block:
        return _enumerate(normal, offset, pref, v_max, pool)
    # rows are independent: bound the (rows, candidates, lines) arrays
    return np.concatenate(
        [
            _enumerate(
                normal[at : at + block],
                offset[at : at + block],
                pref[at : at + block],
                v_max,
                pool if pool.ndim == 1 else pool[at : at + block],
            )
            for at in range(0, len(pref), block)
        ]
    )


def _enumerate(n, c, pref, v_max, pool):
    """:func:`solve_enumerated` on one block of rows."""
    lines = n.shape[1]
    big = c > -_BIG / 2
    speed = np.abs(pref)
    cands = [pool * np.minimum(1.0, v_max / np.maximum(speed, 1e-12))[:, None]]
    along = (pref[:, None] * n.conj()).real
    cands.append(pref[:, None] + (c - along) * n)
    half = np.sqrt(np.maximum(v_max * v_max - c * c, 0.0))
    foot = c * n
    cands += [foot + half * 1j * n, foot - half * 1j * n]
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


def forward_speed(
    normal, offset, h, v_want, v_max: float, slack=0.0, p: OrcaLaw = DEFAULT
) -> np.ndarray:
    """Speed v along each heading h nearest ``v_want`` with v h in every half-plane (less
    ``slack``, m/s, per line or for all, on the lines the heading runs nearly along: n . v h
    >= c - slack where |n . h| < ``slack_shallow``) and -``back_share`` v_max <= v <= v_max
    (0: never backwards); where none is, the middle of what the lines leave, which is a stop
    where the lines would have the robot back away."""
    a = (h[:, None] * normal.conj()).real  # a v >= c
    c = offset - np.where(np.abs(a) < p.slack_shallow, slack, 0.0)
    pos, neg = a > 1e-9, a < -1e-9
    lo = np.where(pos, c / np.where(pos, a, 1.0), -np.inf).max(axis=1)
    hi = np.where(neg, c / np.where(neg, a, 1.0), np.inf).min(axis=1)
    lo = np.maximum(lo, -p.back_share * v_max)
    hi = np.minimum(hi, v_max)
    ok = lo <= hi
    v = np.minimum(np.maximum(v_want, lo), hi)
    middle = np.minimum(np.maximum(0.5 * (lo + hi), -p.back_share * v_max), v_max)
    return np.where(ok, v, middle)


def avoid(
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
    p: OrcaLaw = DEFAULT,
    stood=None,
    points=None,
):
    """ORCA commands for the robots ``rows`` whose planned velocity leaves an ORCA half-plane.

    Args:
        z, vel, h: (m,) positions, velocities (x + iy, m and m/s) and unit headings of all
            robots; rows: (n,) the robots that steer themselves.
        pref: (n,) their preferred velocities (toward the aim point), m/s.
        v_want: (n,) the forward speeds their path following asks for, m/s.
        steering: (m,) bool, robots that avoid too (a reciprocal share of one half).
        radius_m: robot radius; v_max: top speed; dt_s: the control period.
        to_obstacle: maps (k,) positions to the nearest obstacle point, x + iy from each.
        lanes: maps (k,) positions and robot indices to the unit left of each one's path
            segment and its room left and right within the segment's free width
            (``PathFollower.lane_room``); where that width is below ``lane_narrow_m`` and an
            obstacle within ``lane_near_m`` of the body (a single lane, here), two more
            half-planes keep it inside, less ``lane_air_m``, over ``tau_obstacle_s``. None:
            only the nearest obstacle point.
        p: the law's settings.
        stood: (m,) bool, robots without progress for ``bias_stand_s`` (:func:`meeting`), or
            None.
        points: with ``wall_lines`` above 1, maps (k,) positions to (k, W) obstacle points
            (:func:`wall_lines`); None: the nearest obstacle point only.

    Returns:
        None when no half-plane binds; else the robots whose plan is replaced and their
        (v, omega) commands, before the wheel limits.
    """
    reach = orca_range_m(radius_m, v_max, p)
    table = neighbour_table(z, rows, reach, p.max_neighbours)
    if table is None:
        return None
    idx, mask = table
    keep = mask.any(axis=1)
    rows, idx, mask = rows[keep], idx[keep], mask[keep]
    normal, offset = pair_planes(z, vel, rows, idx, mask, steering, radius_m, dt_s, p)
    plan = v_want[keep] * h[rows]
    bind = (offset - (plan[:, None] * normal.conj()).real).max(axis=1) > 1e-9
    if not bind.any():
        return None
    pref, rows = pref[keep][bind], rows[bind]
    allow = meeting(z, vel, rows, idx[bind], mask[bind], pref, stood, p)
    args = (normal[bind], offset[bind], pref, radius_m, v_max, to_obstacle, lanes, p, allow)
    return steer_rows(z, h, rows, *args, points)


def meeting(z, vel, rows, idx, mask, pref, stood=None, p: OrcaLaw = DEFAULT):
    """Which robots ``rows`` may take the right-hand bias: all with ``bias_meet_deg`` 180
    (None); else those with a neighbour (``idx``, real where ``mask``) within ``bias_meet_deg``
    of their preferred velocity ``pref`` relative to that neighbour's velocity, and those
    ``stood`` ((m,) bool: no progress for ``bias_stand_s``; None: none)."""
    if p.meet_all:
        return None
    rel = z[idx] - z[rows][:, None]
    d = pref[:, None] - vel[idx]
    toward = (d * rel.conj()).real > p.cos_meet * (np.abs(d) * np.abs(rel))
    allow = (mask & toward).any(axis=1)
    return allow if stood is None else allow | stood[rows]


def pair_planes(z, vel, rows, idx, mask, steering, radius_m: float, dt_s: float, p=DEFAULT):
    """The half-planes of robots ``rows`` against their neighbours ``idx`` (``mask``: the real
    ones; the others get a line that never binds), as :func:`half_planes` returns them."""
    zi, vi = z[rows], vel[rows]
    share = np.where(steering[idx], 0.5, 1.0)
    normal, offset = half_planes(
        z[idx] - zi[:, None],
        vi[:, None] - vel[idx],
        vi[:, None],
        share,
        2.0 * (radius_m + p.margin_m),
        1.0 / p.tau_s,
        1.0 / dt_s,
    )
    return np.where(mask, normal, 1.0), np.where(mask, offset, -_BIG)


def wall_lines(
    z, rows, radius_m, to_obstacle, lanes=None, ob=None, p: OrcaLaw = DEFAULT, points=None
):
    """The half-planes that keep robots ``rows`` off the obstacles: the nearest obstacle point
    (horizon ``tau_obstacle_s``, air ``wall_gap_m``), or with ``points`` one per obstacle point
    it gives, and, with ``lanes``, the two sides of a single lane (as :func:`avoid` says): (n,
    W) or (n, W + 2) normals and offsets. ``ob``: the nearest obstacle points when the caller
    has them already (``to_obstacle(z[rows])``). ``points``: maps (k,) positions to (k, W)
    obstacle points (``PathFollower.obstacle_points``, inf where none), or None."""
    r_eff = radius_m + p.margin_m
    zi = z[rows]
    ob = to_obstacle(zi) if ob is None else ob
    pts = ob[:, None] if points is None else points(zi)
    normal, offset = obstacle_plane(pts, r_eff + p.wall_gap_m, 1.0 / p.tau_obstacle_s)
    if lanes is not None:
        left, room_l, room_r = lanes(zi, rows)
        real = (np.abs(left) > 0.5) & (room_l + room_r < p.lane_narrow_m)
        real &= np.abs(ob) < radius_m + p.lane_near_m  # ... and between walls here, not past them
        lane_n = np.column_stack([np.where(real, -left, 1.0), np.where(real, left, 1.0)])
        room = np.column_stack([room_l, room_r]) - p.lane_air_m
        lane_c = np.where(real[:, None] & np.isfinite(room), -room / p.tau_obstacle_s, -_BIG)
        normal = np.concatenate([normal, lane_n], axis=1)
        offset = np.concatenate([offset, lane_c], axis=1)
    return normal, offset


def command(normal, offset, pref, hi, v_max, slack=0.0, p: OrcaLaw = DEFAULT):
    """(v, omega) of robots with headings ``hi`` under the half-planes ``normal``, ``offset``:
    the velocity u nearest ``pref`` (:func:`solve`), the turn toward it and the forward speed
    along the heading that keeps every half-plane, less ``slack`` (:func:`forward_speed`)."""
    u = solve(normal, offset, pref, v_max)
    local = u * hi.conj()
    err = np.arctan2(local.imag, local.real)
    align = np.clip((np.cos(err) - p.cos_turn) / (1.0 - p.cos_turn), 0.0, 1.0)
    v = forward_speed(normal, offset, hi, np.abs(u) * align, v_max, slack, p)
    return v, err * p.heading_gain


def steer_rows(
    z,
    h,
    rows,
    normal,
    offset,
    pref,
    radius_m,
    v_max,
    to_obstacle,
    lanes=None,
    p=DEFAULT,
    allow=None,
    points=None,
):
    """The commands of robots ``rows`` whose plan leaves one of their half-planes (``normal``,
    ``offset``: (n, K) from :func:`pair_planes`): the obstacle and lane half-planes added
    (:func:`wall_lines`), the velocity (:func:`solve`) and the forward speed along the heading
    (as :func:`avoid`). The preferred velocity is turned right (``keep_right``) where the body
    has more than ``bias_room_m`` of room to the nearest obstacle (everywhere, by default), of
    the robots ``allow`` ((n,) bool from :func:`meeting`; None: all)."""
    ob = to_obstacle(z[rows])
    on, oc = wall_lines(z, rows, radius_m, to_obstacle, lanes, ob, p, points)
    slack = np.repeat([p.robot_slack_mps, p.wall_slack_mps], [normal.shape[1], on.shape[1]])
    normal = np.concatenate([normal, on], axis=1)
    offset = np.concatenate([offset, oc], axis=1)
    room = np.abs(ob) - radius_m > p.bias_room_m
    bias = np.where(room if allow is None else room & allow, p.keep_right, 1.0)
    v, w = command(normal, offset, pref * bias, h[rows], v_max, slack, p)
    return rows, v, w


def steer_walls(
    z, h, rows, v_plan, pref, radius_m, v_max, to_obstacle, lanes=None, p=DEFAULT, points=None
):
    """Walls as ORCA lines for robots that no robot half-plane binds: of robots ``rows`` (those
    that steer themselves and could be within reach of a wall, ``sim.spatial.control.avoidance``),
    the ones whose plan ``v_plan`` along the heading leaves an obstacle or lane half-plane
    (:func:`wall_lines`) take the velocity nearest their preferred one ``pref`` inside them
    (sliding along the wall rather than creeping into it) and the forward speed along the
    heading that keeps them, at most ``|v_plan|`` (the caps toward robots stay) and never
    backwards: this program has no robot half-planes, and a robot backing off a wall drove into
    the robot behind it (the robot-robot impacts of paper_spatial were that); stopped, it
    turns toward the velocity it chose, in place, which moves its centre nowhere. No
    right-hand bias: it would turn the robot toward the wall it follows.

    Args:
        z, h: (m,) positions and unit headings; rows: (n,) sorted robot indices.
        v_plan: (n,) their speed commands so far, m/s; pref: (n,) their preferred velocities.

    Returns:
        The robots whose command this sets and their (v, omega) commands, before the wheel
        limits; None when no obstacle half-plane binds.
    """
    normal, offset = wall_lines(z, rows, radius_m, to_obstacle, lanes, p=p, points=points)
    plan = v_plan * h[rows]
    bind = (offset - (plan[:, None] * normal.conj()).real).max(axis=1) > 1e-9
    if not bind.any():
        return None
    hi, cap = h[rows[bind]], np.abs(v_plan[bind])
    v, w = command(normal[bind], offset[bind], pref[bind], hi, v_max, p.wall_slack_mps, p)
    return rows[bind], np.minimum(np.maximum(v, 0.0), cap), w
