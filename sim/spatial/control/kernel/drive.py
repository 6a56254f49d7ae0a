"""The drive law for one robot, compiled: path aim, steering, speed caps and wheel limits.

Each function is one of the numpy law's, written for one robot with the same arithmetic in
the same order: :func:`load_segment` and :func:`aim` are ``PathFollower._load`` and
``PathFollower.targets``, :func:`steer` ``DiffDriveController.steer`` with
``sim.spatial.law.drive.preferred_velocity``, :func:`approach_cap` and :func:`pair_cap` the caps of
``DiffDriveController.proximity`` and ``wall_cap``, :func:`limit` ``DiffDriveController.limit``
and :func:`drifting` ``PathFollower.drifting``. ``sim.spatial.controller`` and
``sim.spatial.navigation.paths`` explain the rules.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim.spatial.control.kernel.freewidth import refine


@njit(cache=True)
def load_segment(j, fol, switch_m):
    """Robot j's current-segment entries from its waypoint index (``PathFollower._load``).
    ``fol``: the follower's arrays (:class:`sim.spatial.control.kernel.period.Follower`)."""
    idx = fol.index[j]
    tgt = fol.points[j, idx]
    seg = tgt - fol.points[j, max(idx - 1, 0)]
    length = abs(seg)
    fol.tgt[j], fol.seg_m[j] = tgt, length
    fol.unit_c[j] = seg.conjugate() / max(length, 1e-12) if length > 0.0 else 0j
    fol.after[j], fol.corner2[j] = fol.after_m[j, idx], fol.corner2_m[j, idx]
    more = idx < fol.last[j]
    fol.switch[j] = switch_m if more else -1.0
    fol.beyond[j] = 0.0 if more else -np.inf
    fol.free[0, j], fol.free[1, j] = -fol.free_m[j, idx, 0], fol.free_m[j, idx, 1]
    fol.capped[0, j], fol.capped[1, j] = fol.capped_m[j, idx, 0], fol.capped_m[j, idx, 1]


@njit(cache=True)
def aim(j, z, fol, shapes, law):
    """Advance robot j past a reached waypoint and pick where it steers (``targets``; a
    width only known to be at least ``cap_m`` is refined where the robot is beyond it).

    Returns:
        The aim point minus its position (x + iy), the distance to the waypoint, the path
        left, the squared corner speed there, whether it is beyond the free width of its
        segment, and how many times the follower's arrays changed (a waypoint passed, a width
        refined).
    """
    delta = fol.tgt[j] - z
    gap = abs(delta)
    proj = delta * fol.unit_c[j]
    advanced = 0
    if gap < fol.switch[j] or proj.real < fol.beyond[j]:
        advanced = 1  # near the waypoint or beyond its normal line
        fol.index[j] += 1
        load_segment(j, fol, law.switch_m)
        delta = fol.tgt[j] - z
        gap = abs(delta)
        proj = delta * fol.unit_c[j]
    side = proj.imag  # minus the robot's offset to the left of the segment
    off = side < fol.free[0, j] or side > fol.free[1, j]
    if off and refine(j, side, side, fol, shapes, law.radius_m):
        advanced += 1
        off = side < fol.free[0, j] or side > fol.free[1, j]
    target = delta
    if off:  # straight for the waypoint could touch an obstacle: steer for the path ahead
        back = min(max(proj.real - law.lookahead_m, 0.0), fol.seg_m[j])
        target = delta - back * fol.unit_c[j].conjugate()
    return target, gap, gap + fol.after[j], fol.corner2[j], off, advanced


@njit(cache=True)
def steer(hc, target, gap, corner2, law):
    """The desired (v, omega) toward ``target`` (``DiffDriveController.steer``) and the
    preferred velocity of ORCA (``preferred_velocity``)."""
    local = target * hc
    err = math.atan2(local.imag, local.real)
    v = math.cos(err) * law.align_gain + law.align_bias
    stop = math.sqrt(gap * (2.0 * law.brake_mps2) + corner2)
    v = max(v, 0.0)
    v = min(v, stop)
    speed = min(math.sqrt(gap * (2.0 * law.brake_mps2) + corner2), law.v_max_mps)
    pref = target * (speed / (abs(target) + 1e-12))
    return v, err * law.heading_gain, pref


@njit(cache=True)
def approach_cap(share_m, tau, law):
    """Top speed that covers at most ``share_m`` toward an obstacle at bearing cosine ``tau``
    (> 0), at least the creep speed toward it (``approach_cap_mps``)."""
    cap = math.sqrt(share_m / tau * law.two_a + law.at2) - law.at
    creep = law.creep_mps / tau
    return max(cap, creep)


@njit(cache=True)
def stopping_time(v_mps, law):
    """Distance per m/s of closing speed a robot at ``v_mps`` covers before it stands, s."""
    return law.react_s + abs(v_mps) * law.inv2a


@njit(cache=True)
def pair_cap(rel, dist, cos_i, toward, hc_k, v0_i, v0_k, law):
    """The speed cap of robot i toward robot k (``DiffDriveController.proximity`` for one
    pair): k at ``rel`` (x + iy from i), ``dist`` (>= 1e-9) away, at bearing cosine ``cos_i``
    from i's heading and ``toward`` (> 0) in its direction of travel; ``v0``: the speeds both
    committed to in the last period."""
    mine = cos_i * v0_i
    back = (rel * hc_k).real
    back /= dist
    back *= -v0_k
    gap = max(dist - law.contact_m, 0.0)
    away = min(back, 0.0)
    back = max(back, 0.0)
    their = back * stopping_time(v0_k, law)
    their -= away * away * law.credit
    mine = max(mine, 0.0)
    mine *= stopping_time(v0_i, law)
    share = gap - their
    half = (share + mine) * 0.5
    share = max(min(share, half), 0.0)
    return approach_cap(share, max(toward, 1e-9), law)


@njit(cache=True)
def wall_cap(hc, v, to_wall, law):
    """Robot speed ``v`` capped toward its nearest obstacle point ``to_wall``
    (``DiffDriveController.wall_cap``)."""
    dist = abs(to_wall)
    tau = (to_wall * hc).real / max(dist, 1e-12) * np.sign(v)
    tau = max(tau, 1e-9)
    cap = approach_cap(max(dist - law.radius_m, 0.0), tau, law)
    return max(min(v, cap), -cap)


@njit(cache=True)
def drifting(j, z, h, v_mps, fol, shapes, law):
    """True if robot j, or the point where it could stop, is beyond the free width of its
    segment (``PathFollower.drifting``; a width only known to be at least ``cap_m`` refined
    where it matters); and whether a width was refined."""
    side = ((fol.tgt[j] - z) * fol.unit_c[j]).imag
    stop = (h * fol.unit_c[j]).imag
    stop *= v_mps * (law.react_s + abs(v_mps) * law.inv2a)
    stop = side - stop
    lo, hi = min(side, stop), max(side, stop)
    out = lo < fol.free[0, j] or hi > fol.free[1, j]
    refined = out and refine(j, lo, hi, fol, shapes, law.radius_m)
    if refined:
        out = lo < fol.free[0, j] or hi > fol.free[1, j]
    return out, refined


@njit(cache=True)
def _clip(x, bound):
    return min(max(x, -bound), bound)


@njit(cache=True)
def limit(v, w, v0, q0, turn_first, orca, law):
    """The wheel-speed and wheel-acceleration limits of one robot (``limit``): the (v, omega,
    q) it is commanded, from the wanted (v, omega) and last period's (v0, q0)."""
    s = law.rim_step_mps
    q1 = w * law.half_base_m
    over = (abs(v) + abs(q1)) * (1.0 / law.rim_max_mps)
    over = max(over, 1.0)
    dv = v / over
    brake = abs(dv) < abs(v0)
    dv -= v0
    q_target = q1 / over
    dq = q_target - q0
    right, left = _clip(dv + dq, s), _clip(dv - dq, s)
    if brake:  # slowing down comes first: the turn gets what is left
        dv = _clip(dv, s)
        room = s - abs(dv)
        dq = _clip(dq, room)
        right, left = dv + dq, dv - dq
    elif turn_first and not orca and abs(q0) > law.turn_first_mps:
        if abs(q_target) < abs(q0) or q_target * q0 < 0.0:  # a fast turn must slow first
            dq_t = _clip(dq, s)
            room = s - abs(dq_t)
            dv_t = _clip(dv, room)
            right, left = dv_t + dq_t, dv_t - dq_t
    v_out = (right + left) * 0.5 + v0
    q_out = (right - left) * 0.5 + q0
    return v_out, q_out * (1.0 / law.half_base_m), q_out
