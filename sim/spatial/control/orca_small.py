"""ORCA for a small team (``sim.spatial.law.orca`` for the scalar control period): the same
commands as :func:`sim.spatial.law.orca.avoid`, bit for bit, with most periods never reaching numpy.

For a handful of robots numpy's overhead per call, not arithmetic, is the cost of the law. Its
first steps (the nearest robots in range, their half-planes, whether the plan leaves one) run
here in plain Python; the commands of the robots whose plan does come from
``sim.spatial.law.orca``'s numpy code, because numpy's complex arithmetic (fused multiply-add)
and Python's differ in the last bits. ``tests/parity/test_orca_fast.py`` holds the parity.
"""

from __future__ import annotations

from math import sqrt

import numpy as np

from sim.spatial.law import orca
from sim.spatial.law.orca import DEFAULT, OrcaLaw


def half_plane_one(rel_p: complex, rel_v: complex, vel_i: complex, share: float, combined_m, tau):
    """:func:`sim.spatial.law.orca.half_planes` of one pair in Python complex numbers; ``tau`` is
    the pair ``(1 / horizon, 1 / control period)``."""
    inv_tau, inv_dt = tau
    r2 = combined_m * combined_m
    dist2 = rel_p.real * rel_p.real + rel_p.imag * rel_p.imag
    w = rel_v - rel_p * inv_tau
    if dist2 > r2:
        w2 = w.real * w.real + w.imag * w.imag
        dot1 = (w * rel_p.conjugate()).real
        if not (dot1 < 0.0 and dot1 * dot1 > r2 * w2):  # a leg of the cone
            leg = sqrt(dist2 - r2)
            if (rel_p.conjugate() * w).imag > 0.0:
                direction = rel_p * complex(leg, combined_m) / dist2
            else:
                direction = -(rel_p * complex(leg, -combined_m)) / dist2
            u = (rel_v * direction.conjugate()).real * direction - rel_v
            normal = 1j * direction
            return normal, ((vel_i + share * u) * normal.conjugate()).real
        scale = combined_m * inv_tau
    else:  # inside a collision: the cut-off circle of the control period
        w = rel_v - rel_p * inv_dt
        w2 = w.real * w.real + w.imag * w.imag
        scale = combined_m * inv_dt
    w_len = sqrt(w2 if w2 > 1e-18 else 1e-18)
    unit_w = w / w_len
    u = (scale - w_len) * unit_w
    normal = unit_w  # 1j * (-1j unit_w)
    return normal, ((vel_i + share * u) * normal.conjugate()).real


def avoid_small(
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
    """:func:`sim.spatial.law.orca.avoid` for a small team: the same commands bit for bit, most
    periods without numpy.

    For a handful of robots :func:`avoid` costs numpy's overhead per call, several hundred
    microseconds, and in most periods no half-plane binds. Here the law's first steps (the
    nearest robots in range, the half-planes, which of them the plan leaves) are done in plain
    Python (:func:`binding`), and only the robots whose plan leaves one get their half-planes
    and commands from numpy (:func:`pair_planes`, :func:`steer_rows`), as :func:`avoid`
    computes them: numpy's complex arithmetic (fused multiply-add) and Python's differ in the
    last bits, so the commands themselves must come from numpy. Where rounding could change a
    decision (two neighbours at the same distance, one at the edge of range, a plan within
    1e-10 of the law's threshold), :func:`avoid` decides on the robots that may bind.

    Args:
        as :func:`avoid`.
    """
    m = len(z)
    k = min(p.max_neighbours, m - 1)
    if k < 1 or not len(rows):
        return None
    found = binding(z, vel, h, rows, v_want, steering, radius_m, v_max, dt_s, p)
    if found is None:  # too close to call in Python: the law decides on the robots kept
        keep = np.array(may_bind(z, vel, h, rows, v_want, steering, radius_m, v_max, dt_s, p))
        if not len(keep):
            return None
        args = (z, vel, h, rows[keep], pref[keep], v_want[keep], steering, radius_m, v_max)
        return orca.avoid(*args, dt_s, to_obstacle, lanes, p, stood, points)
    if not found:
        return None
    idx = np.zeros((len(found), k), dtype=np.intp)
    mask = np.zeros((len(found), k), dtype=bool)
    for b, (_, near) in enumerate(found):
        idx[b, : len(near)] = near
        mask[b, : len(near)] = True
    place = np.array([row for row, _ in found])
    rows, pref = rows[place], pref[place]
    normal, offset = orca.pair_planes(z, vel, rows, idx, mask, steering, radius_m, dt_s, p)
    allow = orca.meeting(z, vel, rows, idx, mask, pref, stood, p)
    args = (normal, offset, pref, radius_m, v_max, to_obstacle, lanes, p, allow, points)
    return orca.steer_rows(z, h, rows, *args)


def binding(
    z, vel, h, rows, v_want, steering, radius_m: float, v_max: float, dt_s: float, p=DEFAULT
):
    """:func:`avoid`'s first steps in plain Python: for each robot of ``rows`` whose plan leaves
    one of the half-planes of its ``max_neighbours`` nearest robots in range by more than 1e-9,
    its place in ``rows`` and those neighbours, nearest first; None where rounding could decide
    (distances within 1e-12 of each other or of the range, a plan within 1e-10 of 1e-9)."""
    m = len(z)
    k_max = min(p.max_neighbours, m - 1)
    reach = orca.orca_range_m(radius_m, v_max, p)
    edge = reach * 1e-12
    zs, vs, hs = z.tolist(), vel.tolist(), h.tolist()
    steer, want = steering.tolist(), v_want.tolist()
    combined = 2.0 * (radius_m + p.margin_m)
    tau = (1.0 / p.tau_s, 1.0 / dt_s)
    found = []
    for row, j in enumerate(rows.tolist()):
        zj, vj = zs[j], vs[j]
        near = []
        for k, zk in enumerate(zs):
            if k != j:
                d = abs(zk - zj)
                if d < reach + edge:
                    if d > reach - edge:
                        return None
                    near.append((d, k))
        if not near:
            continue
        near.sort()  # nearest first, ties by index: the order of neighbour_table
        for a in range(min(len(near), k_max + 1) - 1):
            if near[a + 1][0] - near[a][0] <= edge:
                return None
        near = near[:k_max]
        plan = want[row] * hs[j]
        worst = -np.inf
        for _, k in near:
            share = 0.5 if steer[k] else 1.0
            n, c = half_plane_one(zs[k] - zj, vj - vs[k], vj, share, combined, tau)
            worst = max(worst, c - (plan * n.conjugate()).real)
        if abs(worst - 1e-9) <= 1e-10:
            return None
        if worst > 1e-9:
            found.append((row, [k for _, k in near]))
    return found


def may_bind(
    z, vel, h, rows, v_want, steering, radius_m: float, v_max: float, dt_s: float, p=DEFAULT
):
    """Places in ``rows`` of the robots whose plan (``v_want`` along the heading) leaves the
    half-plane of a robot within range (:func:`half_plane_one`), in plain Python; a robot
    not listed has no binding half-plane in :func:`avoid`. Arguments as :func:`avoid`."""
    m = len(z)
    if m < 2 or not len(rows):
        return []
    reach = orca.orca_range_m(radius_m, v_max, p) * (1.0 + 1e-9)
    zs, vs, hs = z.tolist(), vel.tolist(), h.tolist()
    steer, want = steering.tolist(), v_want.tolist()
    combined = 2.0 * (radius_m + p.margin_m)
    tau = (1.0 / p.tau_s, 1.0 / dt_s)
    keep = []
    for row, j in enumerate(rows.tolist()):
        zj, vj = zs[j], vs[j]
        plan = want[row] * hs[j]
        for k, zk in enumerate(zs):
            if k == j or abs(zk - zj) >= reach:
                continue
            share = 0.5 if steer[k] else 1.0
            n, c = half_plane_one(zk - zj, vj - vs[k], vj, share, combined, tau)
            if c - (plan * n.conjugate()).real > 0.0:
                keep.append(row)
                break
    return keep
