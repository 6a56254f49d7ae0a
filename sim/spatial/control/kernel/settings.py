"""The settings the compiled control period reads, as two flat tuples of plain numbers.

The kernel (``sim.spatial.control.kernel``) takes every setting as an argument, never as a
global: a scenario with other settings runs the same compiled code. :class:`DriveLaw` holds the
drive law's numbers (``[spatial.law]``, ``[spatial.drive]``, ``[spatial.follow]``,
``[spatial.recovery]`` as :class:`sim.spatial.controller.DiffDriveController` derives them),
:class:`AvoidLaw` ORCA's (:class:`sim.spatial.law.orca.OrcaLaw`). Both are built once per world
by :func:`drive_law` and :func:`avoid_law`.
"""

from __future__ import annotations

from typing import NamedTuple

from sim.spatial.law.orca import OrcaLaw


class DriveLaw(NamedTuple):
    """The drive law's settings, SI units (each as ``DiffDriveController`` names it)."""

    heading_gain: float  # turn rate per radian of heading error, 1/s
    align_gain: float  # speed from the cosine of the heading error: gain * cos + bias, m/s
    align_bias: float
    brake_mps2: float  # braking deceleration toward a waypoint, m/s^2
    v_max_mps: float  # top speed, m/s
    switch_m: float  # aim at the next waypoint this close to the current one, m
    lookahead_m: float  # off its path, steer for the path this far ahead, m
    progress_m: float  # path left must fall by this much to count as progress, m
    recovered_m: float  # this much past where it got stuck, a robot's tries start again, m
    radius_m: float  # robot radius, m
    contact_m: float  # centre distance at contact, m
    look_m: float  # farther apart than this, no proximity cap binds, m
    react_s: float  # reaction time of the proximity caps (and ORCA's collision period), s
    inv2a: float  # 1 / (2 a), a the proximity deceleration, s^2/m
    two_a: float  # 2 a, m/s^2
    at: float  # a T, m/s
    at2: float  # (a T)^2
    creep_mps: float  # closing speed still allowed on contact, m/s
    cos_ahead: float  # a robot within this bearing cosine is in the way
    credit: float  # 1 / (2 a_wheel): braking distance per (m/s)^2 of a robot moving away
    keep_right_m: float  # centre distance within which keep-right turns, m
    keep_right_radps: float  # that turn, rad/s
    same_way_cos: float  # headings within arccos of this go the same way
    rim_step_mps: float  # a rim's speed change per control period at most, m/s
    half_base_m: float  # half the wheel base, m
    rim_max_mps: float  # top rim speed, m/s
    turn_first_mps: (
        float  # with avoidance, a turn faster than this (as q = omega b / 2) slows first
    )


class AvoidLaw(NamedTuple):
    """ORCA's settings (:class:`sim.spatial.law.orca.OrcaLaw`, where each is explained)."""

    tau_s: float
    tau_obstacle_s: float
    margin_m: float
    wall_gap_m: float
    lane_air_m: float
    lane_narrow_m: float
    lane_near_m: float
    max_neighbours: int
    wall_lines: int
    back_share: float
    robot_slack_mps: float
    wall_slack_mps: float
    slack_shallow: float
    keep_right: complex
    bias_room_m: float
    meet_all: bool
    cos_meet: float
    bias_stand_s: float
    heading_gain: float
    cos_turn: float


def drive_law(controller, follower, recovery) -> DriveLaw:
    """The drive law of a world's controller (:class:`DiffDriveController`), path follower
    (:class:`PathFollower`) and recovery settings (``[spatial.recovery]``)."""
    c = controller
    return DriveLaw(
        heading_gain=float(c.heading_gain),
        align_gain=float(c.align_gain_),
        align_bias=float(c.align_bias_),
        brake_mps2=float(c.brake_mps2),
        v_max_mps=float(c.v_max_mps),
        switch_m=float(follower.switch_m),
        lookahead_m=float(follower.lookahead_m),
        progress_m=float(recovery.progress_m),
        recovered_m=float(recovery.recovered_m),
        radius_m=float(c.radius_m),
        contact_m=float(c.contact_m),
        look_m=float(c.look_m),
        react_s=float(c.react_s),
        inv2a=float(c.inv2a_),
        two_a=float(c.two_a_),
        at=float(c.at_),
        at2=float(c.at2_),
        creep_mps=float(c.creep_mps),
        cos_ahead=float(c.cos_ahead),
        credit=float(0.5 / c.wheel_decel_),
        keep_right_m=float(c.keep_right_m),
        keep_right_radps=float(c.keep_right_gain * c.omega_max_radps),
        same_way_cos=float(c.same_way_cos),
        rim_step_mps=float(c.rim_step_mps),
        half_base_m=float(c.half_base_m),
        rim_max_mps=float(c.rim_max_mps),
        turn_first_mps=float(c.turn_first_radps * c.half_base_m),
    )


def avoid_law(p: OrcaLaw) -> AvoidLaw:
    """ORCA's settings as the kernel reads them."""
    return AvoidLaw(
        tau_s=float(p.tau_s),
        tau_obstacle_s=float(p.tau_obstacle_s),
        margin_m=float(p.margin_m),
        wall_gap_m=float(p.wall_gap_m),
        lane_air_m=float(p.lane_air_m),
        lane_narrow_m=float(p.lane_narrow_m),
        lane_near_m=float(p.lane_near_m),
        max_neighbours=int(p.max_neighbours),
        wall_lines=int(p.wall_lines),
        back_share=float(p.back_share),
        robot_slack_mps=float(p.robot_slack_mps),
        wall_slack_mps=float(p.wall_slack_mps),
        slack_shallow=float(p.slack_shallow),
        keep_right=complex(p.keep_right),
        bias_room_m=float(p.bias_room_m),
        meet_all=bool(p.meet_all),
        cos_meet=float(p.cos_meet),
        bias_stand_s=float(p.bias_stand_s),
        heading_gain=float(p.heading_gain),
        cos_turn=float(p.cos_turn),
    )
