"""The drive law's constants and formulas, once: pure functions of floats or of numpy arrays.

Both control periods use them: :class:`sim.spatial.control.ScalarControl` robot by robot with Python
floats and complex numbers, and :class:`sim.spatial.control.ArrayControl` over the robot axis
through :class:`sim.spatial.controller.DiffDriveController` and :class:`sim.spatial.motors.Motors`.
Each function is written with arithmetic operators and ``abs`` only, so the same expression runs on
a float and elementwise on an array with the same IEEE operations in the same order. ``abs`` is
Python's on a Python number and numpy's on an array (the two differ in the last bit for complex
numbers), and a function with no operator (``sqrt``, ``cos``) is passed in by the caller, so each
control period keeps its exact arithmetic and its runs stay bit-for-bit reproducible.

Clipping a result to a range is left to the caller, as each docstring says: a conditional
expression per robot in the scalar period (a function call per clip would cost it more than
the formula), ``np.minimum`` and ``np.maximum`` over arrays.

Points and headings are complex numbers (x + iy and e^{i theta}); wheel state is (v, q = omega
b / 2), rim speeds v +- q. Speeds are in m/s, distances in m, times in s.
"""

from __future__ import annotations

ARC_MAX_RADIUS_M = 1e4  # flatter arcs are driven as straight lines (a numerical tolerance)


def steer_speeds(cos_err, gap_m, corner2, align_gain, align_bias, brake2_mps2, sqrt):
    """The two speeds that bound a robot's forward command toward its waypoint.

    Args:
        cos_err: cosine of the heading error toward the aim point.
        gap_m: distance to the waypoint.
        corner2: squared speed allowed when passing the waypoint (0 at the goal).
        align_gain, align_bias: the affine map from ``cos_err`` to speed, top speed when aligned
            and 0 at the turn-in-place angle (``[spatial.law] turn_in_place_deg``).
        brake2_mps2: twice the braking deceleration.
        sqrt: ``math.sqrt`` or ``np.sqrt``.

    Returns:
        The speed the heading error allows and the speed from which the robot still brakes to
        the corner speed within the gap; the command is the first clipped to [0, the second].
    """
    return cos_err * align_gain + align_bias, sqrt(gap_m * brake2_mps2 + corner2)


def preferred_velocity(aim, gap_m, corner2, brake_mps2, v_max_mps, sqrt, minimum):
    """The velocity a robot would like (x + iy, m/s), the preferred velocity of ORCA: toward
    its aim point ``aim`` (x + iy from its centre) at the speed from which it still brakes at
    ``brake_mps2`` to the corner speed within ``gap_m`` (as ``steer_speeds``), at most
    ``v_max_mps``; zero where ``aim`` is zero. ``sqrt``, ``minimum``: math's or numpy's."""
    speed = minimum(sqrt(gap_m * (2.0 * brake_mps2) + corner2), v_max_mps)
    return aim * (speed / (abs(aim) + 1e-12))


def stopping_time_s(v_mps, react_s, inv2a):
    """Distance a robot at speed ``v_mps`` covers per m/s of it before it stands: the reaction
    time plus |v| / 2a (``inv2a`` = 1 / 2a), s. Times a closing speed, a stopping distance."""
    return react_s + abs(v_mps) * inv2a


def approach_cap_mps(share_m, tau, two_a, at, at2, sqrt, creep_mps):
    """Top speed that covers at most ``share_m`` toward an obstacle at bearing cosine ``tau`` > 0
    when held for the reaction time T and then braked at a: sqrt(2 a s / tau + (a T)^2) - a T.

    Args:
        share_m: the share of the gap the robot may cover, m.
        tau: bearing cosine in the direction of travel (> 0).
        two_a, at, at2: 2 a (m/s^2), a T (m/s) and (a T)^2.
        sqrt: ``math.sqrt`` or ``np.sqrt``.
        creep_mps: the closing speed still allowed on contact (``[spatial.law] creep_mps``).

    Returns:
        The cap and the creep speed toward the obstacle, ``creep_mps / tau``: the cap is at
        least that (the caller takes the larger).
    """
    return sqrt(share_m / tau * two_a + at2) - at, creep_mps / tau


def pair_share_m(gap_m, theirs_m, mine_m):
    """Of the gap between two robots, the share robot i may cover: the gap less k's need less
    k's half of the room that is left, min(g - theirs, (g - theirs + mine) / 2), never below 0.

    Returns:
        g - theirs and (g - theirs + mine) / 2; the caller takes the smaller, at least 0.
    """
    share = gap_m - theirs_m
    return share, (share + mine_m) * 0.5


def rim_speed_mps(v_mps, q_mps):
    """Speed of the faster wheel rim of a robot commanded (v, q): |v| + |q|."""
    return abs(v_mps) + abs(q_mps)


def twist_from_rims(right_mps, left_mps, v0_mps, q0_mps):
    """(v, q) after the rims change by ``right_mps`` and ``left_mps`` from (v0, q0)."""
    return (right_mps + left_mps) * 0.5 + v0_mps, (right_mps - left_mps) * 0.5 + q0_mps


def on_arc(v_mps, omega_radps):
    """True where the command (v, omega) is driven as an arc about a centre of rotation: its
    radius |v / omega| is below ``ARC_MAX_RADIUS_M`` (a flatter one is driven straight)."""
    return abs(v_mps) < abs(omega_radps) * ARC_MAX_RADIUS_M


def control_body(z, h, v_mps, omega_radps, radius_m):
    """Where a robot's kinematic control body sits and how fast it moves (x + iy) to drive the
    robot at (v, omega): at the centre of rotation z + i R h (``radius_m`` = R = v / omega on an
    arc, 0 straight), moving at (v - omega R) h, which is zero on an arc."""
    return radius_m * (1j * h) + z, (v_mps - omega_radps * radius_m) * h


def goes_our_way(th_rad, th_other_rad, cos, same_way_cos):
    """True where the other robot's heading is within arccos(``same_way_cos``) of ours (60
    degrees by default, ``[spatial.law] same_way_cos``; ``cos`` given)."""
    return cos(th_rad - th_other_rad) > same_way_cos


def next_check_s(t_s: float, gap_m: float, closing_mps: float) -> float:
    """The earliest time a gap of ``gap_m`` (0 if negative) could close at ``closing_mps``."""
    return t_s + max(gap_m, 0.0) / closing_mps
