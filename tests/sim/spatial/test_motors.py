"""Robot bodies and motor joints (``sim.spatial.motors.Motors``) in a bare pymunk space: what they
are built with, what a read and a write do to the buffer and the bodies, and the checkpoint round
trip."""

from __future__ import annotations

import math

import numpy as np
import pymunk
import pytest

from sim.scenario import DriveSpec
from sim.spatial.law.drive import ARC_MAX_RADIUS_M, control_body, on_arc
from sim.spatial.motors import Motors, _rows, control_records
from tests.golden.cases import in_baseline_child

DRIVE = DriveSpec()
STARTS = np.array([[1.0, 2.0], [4.0, 2.0], [7.0, 5.0]])
HEADINGS = np.array([0.0, math.pi / 2, -0.5])
ROBOT = 7  # a collision type


def fleet(headings=HEADINGS, starts=STARTS, buffer=None) -> tuple[pymunk.Space, Motors]:
    space = pymunk.Space()
    return space, Motors(space, DRIVE, starts, ROBOT, headings, buffer)


def drive(space: pymunk.Space, mo: Motors, steps: int, v, w) -> None:
    """``steps`` physics steps of 1/60 s, the command (v, w) written from the pose read every
    sixth step (a 0.1 s control period)."""
    for k in range(steps):
        rob = mo.read()
        if k % 6 == 0:
            z, th = rob["z"].copy(), rob["th"].copy()
            mo.write(z, th, np.exp(1j * th), np.array(v), np.array(w))
        space.step(1.0 / 60.0)


def test_robots_are_circles_with_the_drive_s_mass_and_tyres():
    space, mo = fleet()
    assert len(mo.bodies) == 3 and len(mo.pivots) == 3
    for body, xy, th in zip(mo.bodies, STARTS, HEADINGS, strict=True):
        assert body.body_type == pymunk.Body.DYNAMIC
        assert body.mass == 20.0 and body.moment == pytest.approx(0.5 * 20.0 * 0.25**2)
        assert tuple(body.position) == tuple(xy) and body.angle == th
        (shape,) = body.shapes
        assert isinstance(shape, pymunk.Circle) and shape.radius == 0.25
        assert (shape.friction, shape.elasticity, shape.collision_type) == (0.3, 0.0, ROBOT)
    for pivot, body in zip(mo.pivots, mo.bodies, strict=True):
        ctrl = pivot.a
        assert pivot.b is body and ctrl.body_type == pymunk.Body.KINEMATIC
        assert tuple(ctrl.position) == tuple(body.position) and ctrl.angle == body.angle
        assert tuple(pivot.anchor_a) == (0.0, 0.0) and tuple(pivot.anchor_b) == (0.0, 0.0)
        assert pivot.max_bias == 0.0 and pivot.max_force == 20.0 * 6.0
        (gear,) = [c for c in ctrl.constraints if isinstance(c, pymunk.GearJoint)]
        assert (gear.phase, gear.ratio, gear.max_bias) == (0.0, 1.0, 0.0)
        assert gear.max_force == pytest.approx(120.0 * 0.2)  # tyre force times half the base
    assert len(space.bodies) == 6 and len(space.constraints) == 6
    assert len(space.shapes) == 3 and all(s.space is space for b in mo.bodies for s in b.shapes)


def test_one_heading_per_start_is_required():
    with pytest.raises(ValueError, match="zip"):
        fleet(headings=np.zeros(2))


def test_robots_and_controls_must_be_runs_of_buffer_rows(monkeypatch):
    import sim.spatial.motors

    calls = []

    def scattered(rows):  # the control bodies' rows as an index array, as if not in a run
        calls.append(rows)
        return slice(rows[0], rows[0] + len(rows)) if len(calls) == 1 else np.array(rows)

    monkeypatch.setattr(sim.spatial.motors, "_rows", scattered)
    with pytest.raises(
        RuntimeError, match=r"^robots and control bodies must be runs of batch buffer rows$"
    ):
        fleet()


def test_without_headings_every_robot_faces_x():
    _, mo = fleet(headings=None)
    assert [b.angle for b in mo.bodies] == [0.0, 0.0, 0.0]
    assert mo.read()["th"].tolist() == [0.0, 0.0, 0.0]


def test_read_gives_every_robot_s_pose_and_velocity_as_records():
    _, mo = fleet()
    mo.bodies[1].velocity = (0.5, -0.25)
    mo.bodies[2].angular_velocity = 1.5
    rob = mo.read()
    assert rob["z"].tolist() == [1 + 2j, 4 + 2j, 7 + 5j]
    assert rob["th"].tolist() == HEADINGS.tolist()
    assert rob["vel"].tolist() == [0j, 0.5 - 0.25j, 0j]
    assert rob["w"].tolist() == [0.0, 0.0, 1.5]
    assert mo.flat.shape == (3, 6) and mo.flat[1].tolist() == [
        4.0,
        2.0,
        math.pi / 2,
        0.5,
        -0.25,
        0.0,
    ]
    assert mo.ctl_flat.shape == (18,) and mo.ctl_flat[6:9].tolist() == [4.0, 2.0, math.pi / 2]
    mo.bodies[0].position = (3.0, 3.0)
    assert mo.read()["z"][0] == 3 + 3j  # a read is fresh each time


def test_write_puts_each_control_body_where_its_command_needs_it():
    _, mo = fleet()
    rob = mo.read()
    z, th = rob["z"].copy(), rob["th"].copy()
    h = np.exp(1j * th)
    v, w = np.array([1.0, 0.5, 0.0]), np.array([0.0, 0.25, 2.0])  # straight, arc, in place
    mo.write(z, th, h, v, w)
    ctl = [p.a for p in mo.pivots]
    assert tuple(ctl[0].velocity) == pytest.approx((1.0, 0.0)) and ctl[0].position == (1.0, 2.0)
    # the arc: centre of rotation 2 m to the left of robot 1 (heading +y): at (2, 2)
    assert tuple(ctl[1].position) == pytest.approx((2.0, 2.0), abs=1e-12)
    assert tuple(ctl[1].velocity) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert ctl[1].angular_velocity == 0.25 and ctl[1].angle == math.pi / 2
    assert tuple(mo.pivots[1].anchor_a) == pytest.approx((0.0, -2.0))
    # in place: on the robot, not moving, turning
    assert tuple(ctl[2].position) == pytest.approx((7.0, 5.0)) and ctl[2].angular_velocity == 2.0
    assert tuple(mo.pivots[0].anchor_a) == (0.0, 0.0) and tuple(mo.pivots[2].anchor_a) == (0, 0)
    # robot rows were written back unchanged
    assert [tuple(b.position) for b in mo.bodies] == [tuple(p) for p in STARTS]
    assert mo.state_arrays()["arc_radius_array"].tolist() == [0.0, 2.0, 0.0]


def record_cases(seed: int, cases: int = 300, m: int = 9):
    """(records, radii, changed robots) from :func:`control_records` and from numpy's law
    (``control_body``, ``on_arc``) for random commands: straight, arcs, turns in place, arcs
    too flat to drive as arcs, stops; pivots anchored at random, some at the new radius."""
    rng = np.random.default_rng(seed)
    for _ in range(cases):
        z = rng.normal(0, 5, m) + 1j * rng.normal(0, 5, m)
        th = rng.uniform(-4.0, 4.0, m)
        h = np.exp(1j * th)
        v = rng.choice([0.0, 1.0, -0.3, 1e-5], m) * rng.uniform(0.0, 1.0, m)
        w = rng.choice([0.0, 1.0, -2.0, 1e-9], m) * rng.uniform(0.0, 1.0, m)
        radius = np.zeros(m)
        np.divide(v, w, out=radius, where=on_arc(v, w))
        anchor = np.where(rng.random(m) < 0.5, radius, rng.choice([0.0, 1.0], m))
        centre, vel = control_body(z, h, v, w, radius)
        want = np.column_stack([centre.real, centre.imag, th, vel.real, vel.imag, w]).ravel()
        rec, got_radius, changed = np.zeros(6 * m), np.zeros(m), np.zeros(m, dtype=np.int64)
        n = control_records(z, h, th, v, w, rec, got_radius, anchor, changed)
        yield (rec, got_radius, changed[:n]), (want, radius, (anchor != radius).nonzero()[0])


def record_mismatches(seed: int) -> list[int]:
    """[values compared, values not numpy's to the last bit] over :func:`record_cases`."""
    tally = [0, 0]
    for got, want in record_cases(seed):
        for g, w in zip(got[:2], want[:2], strict=True):
            tally[0] += g.size
            tally[1] += int((g.view(np.uint64) != w.view(np.uint64)).sum())
    return tally


def test_control_records_are_numpys_law():
    """The compiled records agree with the numpy law within rounding here, the radii exactly,
    and the robots whose pivots need a new anchor are those whose radius changed, in order;
    the cases reach straight runs, arcs and arcs too flat to be driven as arcs."""
    kinds = set()
    for (rec, radius, changed), (want, want_radius, want_changed) in record_cases(0):
        np.testing.assert_allclose(rec, want, rtol=0, atol=1e-12)
        assert radius.tolist() == want_radius.tolist()
        assert changed.tolist() == want_changed.tolist()
        kinds |= {"arc" if r else "straight" for r in radius.tolist()}
        kinds |= {"changed"} if len(changed) else set()
    assert kinds == {"arc", "straight", "changed"}


def test_control_records_are_numpys_bit_for_bit_with_baseline_kernels():
    """In a child Python with numpy's baseline kernels (what the golden runs use), every
    record and radius is numpy's law's to the last bit."""
    tallies = in_baseline_child(__file__, "[ns['record_mismatches'](s) for s in (0, 1)]")
    for checked, differ in tallies:
        assert checked > 0 and differ == 0, (checked, differ)


def pose(mo: Motors) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, headings and their unit vectors of a fresh read."""
    rob = mo.read()
    z, th = rob["z"].copy(), rob["th"].copy()
    return z, th, np.exp(1j * th)


ARC = np.array([0.0, 0.5, 0.0]), np.array([0.0, 0.25, 0.0])  # robot 1 on an arc of radius 2


def test_a_pivot_is_anchored_again_only_when_its_radius_changes():
    _, mo = fleet()
    z, th, h = pose(mo)
    v, w = ARC
    mo.write(z, th, h, v, w)
    assert tuple(mo.pivots[1].anchor_a) == (0.0, -2.0)
    mo.pivots[1].anchor_a = (0.0, 0.0)  # so a write of the same radius would show
    mo.read()
    mo.write(z, th, h, v, w)
    assert tuple(mo.pivots[1].anchor_a) == (0.0, 0.0)
    mo.read()
    mo.write(z, th, h, v, np.array([0.0, 0.5, 0.0]))  # radius 1 now
    assert tuple(mo.pivots[1].anchor_a) == (0.0, -1.0)
    mo.read()
    mo.write(z, th, h, np.zeros(3), np.zeros(3))  # stopped: straight, radius 0
    assert tuple(mo.pivots[1].anchor_a) == (0.0, 0.0)


def test_a_flat_arc_is_driven_straight():
    _, mo = fleet(headings=np.zeros(3))
    rob = mo.read()
    v = np.array([1.0, 1.0, 1.0])
    w = np.array([1.0 / (ARC_MAX_RADIUS_M * 2.0), 1.0 / (ARC_MAX_RADIUS_M * 0.5), 0.0])
    mo.write(rob["z"].copy(), rob["th"].copy(), np.ones(3, dtype=complex), v, w)
    assert mo.state_arrays()["arc_radius_array"].tolist() == [0.0, ARC_MAX_RADIUS_M * 0.5, 0.0]


def test_driven_robots_follow_their_arcs_without_sliding():
    space, mo = fleet()
    drive(space, mo, 60, [1.0, 0.5, 0.0], [0.0, 0.25, 2.0])  # 1 s
    rob = mo.read()
    # robot 0 straight along +x, robot 1 on the circle of radius 2 about (2, 2), robot 2 turns
    assert rob["z"][0].imag == pytest.approx(2.0, abs=1e-6) and rob["z"][0].real > 1.5
    assert abs(rob["z"][1] - (2 + 2j)) == pytest.approx(2.0, abs=0.01)  # lags while it speeds up
    assert abs(rob["z"][2] - (7 + 5j)) < 1e-6 and rob["th"][2] > -0.5 + 1.5
    sideways = (rob["vel"] * np.exp(-1j * rob["th"])).imag
    assert np.abs(sideways).max() < 1e-3


def test_write_one_commands_one_robot_as_write_does():
    _, a = fleet()
    _, b = fleet()
    z, th, h = pose(a)
    a.write(z, th, h, *ARC)
    b.read()
    b.write_one(1, 2.0, 2.0, math.pi / 2, 0.0, 0.0, 0.25, 2.0)
    sa, sb = a.state_arrays(), b.state_arrays()
    assert np.allclose(sa["controls"], sb["controls"], atol=1e-12)
    assert sb["arc_radius_scalar"].tolist() == [0.0, 2.0, 0.0]
    assert tuple(b.pivots[1].anchor_a) == (0.0, -2.0)
    b.pivots[1].anchor_a = (0.0, 0.0)  # not written again while the radius is the same
    b.write_one(1, 2.0, 2.0, math.pi / 2, 0.0, 0.0, 0.25, 2.0)
    assert tuple(b.pivots[1].anchor_a) == (0.0, 0.0)


def test_a_checkpoint_puts_fresh_bodies_where_the_old_ones_were():
    space, mo = fleet()
    drive(space, mo, 30, [1.0, 0.5, 0.2], [0.0, 0.25, 2.0])
    saved = mo.state_arrays()
    _, fresh = fleet(headings=None, starts=np.zeros((3, 2)))
    fresh.restore_arrays(saved)
    again = fresh.state_arrays()
    for key in saved:
        assert np.array_equal(saved[key], again[key]), key
    assert tuple(fresh.pivots[1].anchor_a) == pytest.approx((0.0, -2.0))
    assert tuple(fresh.pivots[2].anchor_a) == pytest.approx((0.0, -0.1))  # 0.2 / 2 rad/s
    assert tuple(fresh.pivots[0].anchor_a) == (0.0, 0.0)
    rob = fresh.read()  # and it drives on: a write after a restore works
    fresh.write(rob["z"].copy(), rob["th"].copy(), np.ones(3, complex), np.ones(3), np.ones(3))
    assert fresh.state_arrays()["arc_radius_array"].tolist() == [1.0, 1.0, 1.0]


def test_a_checkpoint_keeps_an_arc_of_radius_one():
    _, mo = fleet()
    rob = mo.read()
    mo.write(rob["z"].copy(), rob["th"].copy(), np.ones(3, complex), np.ones(3), np.ones(3))
    _, fresh = fleet(headings=None, starts=np.zeros((3, 2)))
    fresh.restore_arrays(mo.state_arrays())
    assert [tuple(p.anchor_a) for p in fresh.pivots] == [(0.0, -1.0)] * 3


def test_a_checkpoint_for_another_fleet_size_is_refused():
    _, mo = fleet()
    saved = mo.state_arrays()
    _, two = fleet(headings=None, starts=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="zip"):
        two.restore_arrays(saved)
    short = {**saved, "controls": saved["controls"][:2]}
    _, three = fleet(headings=None, starts=np.zeros((3, 2)))
    with pytest.raises(ValueError, match="zip"):
        three.restore_arrays(short)


def test_a_checkpoint_of_the_scalar_path_keeps_its_arc_radii():
    _, mo = fleet()
    mo.read()
    mo.write_one(2, 7.0, 5.4, 0.3, 0.0, 0.0, 2.0, 0.4)
    saved = mo.state_arrays()
    assert saved["arc_radius_array"].tolist() == [0.0, 0.0, 0.0]
    assert saved["arc_radius_scalar"].tolist() == [0.0, 0.0, 0.4]
    _, fresh = fleet(headings=None, starts=np.zeros((3, 2)))
    fresh.restore_arrays(saved)
    assert tuple(fresh.pivots[2].anchor_a) == pytest.approx((0.0, -0.4))
    assert fresh.state_arrays()["arc_radius_scalar"].tolist() == [0.0, 0.0, 0.4]
    assert fresh.state_arrays()["controls"][2].tolist() == [7.0, 5.4, 0.3, 0.0, 0.0, 2.0]


def test_a_buffer_is_reused_by_the_next_fleet():
    _, first = fleet()
    _, second = fleet(buffer=first.buf_)
    assert second.buf_ is first.buf_
    assert second.read()["z"].tolist() == [1 + 2j, 4 + 2j, 7 + 5j]


def test_rows_are_a_slice_when_they_run_on_else_an_index_array():
    assert _rows([3, 4, 5]) == slice(3, 6)
    picked = _rows([0, 2, 3])
    assert (
        isinstance(picked, np.ndarray) and picked.dtype == np.intp and picked.tolist() == [0, 2, 3]
    )
    assert isinstance(_rows([]), np.ndarray) and _rows([]).size == 0 and _rows([]).dtype == np.intp
