"""The two-dimensional programs of ORCA, compiled: RVO2's linearProgram1, 2 and 3.

Lines are half-planes {u : n . u >= c} (unit normal n, complex; offset c), the speed limit a
disc of radius R. :func:`nearest_velocity` is the program a robot solves: the velocity nearest
its preferred one inside every line and the disc (:func:`program2`, incremental as in van den
Berg et al. 2011 and RVO2's ``linearProgram2``: the optimum of the first lines, moved onto the
first line it breaks, is the optimum with that line too). Where no velocity keeps every line,
the first ``n_hard`` lines (walls, lanes) stay hard and the velocity that breaks the others
least is taken (:func:`program3`, RVO2's ``linearProgram3``: the worst violation, in metres per
second, minimised); where the hard lines alone leave nothing inside the disc, every line is soft.

On a feasible program this is the rule of ``sim.spatial.law.orca.solve`` (the same optimum; a line
counts as broken only by more than 1e-9, as there). The infeasible rule replaces that
function's candidate minimax, which weighed walls and robots alike and whose candidate set grew
with the square of the robots in a call.
"""

from __future__ import annotations

import math

from numba import njit

TOL = 1e-9  # a line is broken by more than this (m/s), as in sim.spatial.law.orca.solve
PARALLEL = 1e-9  # |sin| of the angle between two lines below this: parallel


@njit(cache=True)
def _dot(a, b):
    """a . b of two vectors given as complex numbers."""
    return a.real * b.real + a.imag * b.imag


@njit(cache=True)
def _cross(a, b):
    """det(a, b) = a_x b_y - a_y b_x of two vectors given as complex numbers."""
    return a.real * b.imag - a.imag * b.real


@njit(cache=True)
def program1(normal, offset, line, radius, opt, direction_opt):
    """The point of line ``line`` inside the disc and the lines before it, nearest ``opt``
    (or, with ``direction_opt``, farthest along the unit direction ``opt``).

    Returns:
        (True, the point), or (False, 0) when no point of the line is inside them all.
    """
    n_i, c_i = normal[line], offset[line]
    d_i = -1j * n_i  # the line's direction: its allowed side on the left
    p_i = c_i * n_i  # the foot of the line
    dot = _dot(p_i, d_i)
    disc = dot * dot + radius * radius - _dot(p_i, p_i)
    if disc < 0.0:  # the disc lies wholly outside the line
        return False, 0j
    root = math.sqrt(disc)
    t_left, t_right = -dot - root, -dot + root
    for j in range(line):
        a = _dot(normal[j], d_i)  # line j: a t >= b along line i
        b = offset[j] - _dot(normal[j], p_i)
        if abs(a) <= PARALLEL:
            if b > 0.0:  # (almost) parallel and line i lies wholly outside line j
                return False, 0j
            continue
        if a > 0.0:
            t_left = max(t_left, b / a)
        else:
            t_right = min(t_right, b / a)
        if t_left > t_right:
            return False, 0j
    if direction_opt:
        t = t_right if _dot(opt, d_i) > 0.0 else t_left
    else:
        t = _dot(d_i, opt - p_i)
        t = t_left if t < t_left else (t_right if t > t_right else t)
    return True, p_i + t * d_i


@njit(cache=True)
def program2(normal, offset, count, radius, opt, direction_opt, tol):
    """The point inside the disc and the first ``count`` lines nearest ``opt`` (or farthest
    along the unit direction ``opt``), taking the lines one by one.

    Returns:
        (count, the point) when it exists; else (the first line that leaves nothing, the
        optimum of the lines before it).
    """
    if direction_opt:
        u = opt * radius
    else:
        u = opt * min(1.0, radius / max(abs(opt), 1e-12))
    for i in range(count):
        if offset[i] - _dot(normal[i], u) > tol:  # u breaks line i: the optimum lies on it
            ok, got = program1(normal, offset, i, radius, opt, direction_opt)
            if not ok:
                return i, u
            u = got
    return count, u


@njit(cache=True)
def program3(normal, offset, count, n_hard, begin, radius, u, proj_n, proj_c):
    """The velocity inside the disc and the first ``n_hard`` lines that breaks the other lines
    least (the largest ``c - n . u`` smallest), starting from ``u``, which keeps the lines
    before ``begin``. ``proj_n``, ``proj_c``: buffers of at least ``count`` lines."""
    distance = 0.0
    for i in range(begin, count):
        n_i, c_i = normal[i], offset[i]
        if c_i - _dot(n_i, u) <= distance:
            continue
        d_i, p_i = -1j * n_i, c_i * n_i
        for h in range(n_hard):
            proj_n[h], proj_c[h] = normal[h], offset[h]
        k = n_hard
        for j in range(n_hard, i):  # where line j's violation equals line i's
            d_j, p_j = -1j * normal[j], offset[j] * normal[j]
            det = _cross(d_i, d_j)
            if abs(det) <= PARALLEL:
                if _dot(d_i, d_j) > 0.0:  # the same direction: j never binds first
                    continue
                point = 0.5 * (p_i + p_j)
            else:
                point = p_i + (_cross(d_j, p_i - p_j) / det) * d_i
            direction = d_j - d_i
            direction = direction / abs(direction)
            proj_n[k] = 1j * direction
            proj_c[k] = _dot(proj_n[k], point)
            k += 1
        fail, got = program2(proj_n, proj_c, k, radius, n_i, True, 0.0)
        if fail == k:  # else rounding: keep the current velocity
            u = got
        distance = c_i - _dot(n_i, u)
    return u


@njit(cache=True)
def nearest_velocity(normal, offset, count, n_hard, pref, radius, proj_n, proj_c):
    """The velocity a robot takes under the lines ``[:count]`` (the first ``n_hard`` hard) and
    the speed disc: nearest ``pref`` inside them all, else :func:`program3`'s."""
    fail, u = program2(normal, offset, count, radius, pref, False, TOL)
    if fail < count:
        hard = n_hard if fail >= n_hard else 0  # the hard lines alone leave nothing: all soft
        u = program3(normal, offset, count, hard, fail, radius, u, proj_n, proj_c)
    return u
