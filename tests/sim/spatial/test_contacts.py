"""Contacts as ``sim.spatial.contacts.ContactMonitor`` counts them: touch or impact by the closing
speed along the contact normal as the contact begins, robot-robot apart from robot-wall, the solver
iterations that follow the contacts, and the deepest overlap.

Each case is a bare pymunk space with free bodies at set velocities (no damping, no gravity), so
the closing speed at the begin callback is known exactly: nothing else has touched the bodies'
velocities before the contact begins.
"""

from __future__ import annotations

import numpy as np
import pymunk
import pytest

from sim.scenario import ContactSpec
from sim.spatial.contacts import ContactMonitor

# the settings' defaults (sim.scenario), under the names these tests use
CONTACT_ITERATIONS = ContactSpec().iterations
FREE_ITERATIONS = ContactSpec().free_iterations
IMPACT_MPS = ContactSpec().impact_mps


ROBOT, WALL = 1, 2
R = 0.25
DT = 1.0 / 60.0


def space_with(*robots, wall_x=None):
    """A space with robot discs ``(x, y, vx, vy)`` and, if ``wall_x``, a wall along x = wall_x;
    its monitor and the robots' bodies."""
    space = pymunk.Space()
    monitor = ContactMonitor(space, ROBOT, WALL)
    bodies = []
    for x, y, vx, vy in robots:
        body = pymunk.Body(1.0, pymunk.moment_for_circle(1.0, 0.0, R))
        body.position, body.velocity = (x, y), (vx, vy)
        shape = pymunk.Circle(body, R)
        shape.collision_type, shape.elasticity, shape.friction = ROBOT, 0.0, 0.0
        space.add(body, shape)
        bodies.append(body)
    if wall_x is not None:
        wall = pymunk.Segment(space.static_body, (wall_x, -10.0), (wall_x, 10.0), 0.0)
        wall.collision_type, wall.friction = WALL, 0.0
        space.add(wall)
    return space, monitor, bodies


def step_until(monitor, done, limit=600):
    """Step until ``done(monitor)``; fail after ``limit`` steps (10 s) rather than hang."""
    for _ in range(limit):
        if done(monitor):
            return
        monitor.run(1, DT)
    pytest.fail(f"not reached in {limit} steps: touching {monitor.touching}")


def counts(monitor):
    return (monitor.robot_hits, monitor.robot_impacts, monitor.wall_hits, monitor.wall_impacts)


@pytest.mark.parametrize(
    ("va", "vb", "impact"),
    [
        (0.1, -0.1, False),  # closing at 0.2 m/s
        (0.14, -0.14, False),  # 0.28: just below the threshold
        (0.15, -0.15, True),  # exactly IMPACT_MPS (0.3) counts as an impact
        (0.2, -0.2, True),  # 0.4
        (0.4, 0.0, True),  # one robot into a standing one
        (0.0, -0.4, True),  # ... the other way round: the sign of the normal does not matter
        (0.5, 0.3, False),  # both the same way, the rear one catching up at 0.2
        (0.6, 0.2, True),  # ... at 0.4
    ],
)
def test_a_robot_contact_is_an_impact_exactly_from_the_closing_speed_threshold(va, vb, impact):
    assert IMPACT_MPS == 0.3
    _, monitor, _ = space_with((0.0, 0.0, va, 0.0), (0.6, 0.0, vb, 0.0))
    for _ in range(600):
        monitor.run(1, DT)
        if monitor.robot_hits:
            break
    assert counts(monitor) == (1, int(impact), 0, 0)


def test_a_fast_graze_is_a_touch_and_robots_moving_apart_cannot_begin_one():
    """What counts is the speed along the contact normal, not the speed of either robot: a
    robot passing a standing one at 1 m/s with centres 0.49 m apart across its way (the normal
    nearly across the motion: about 0.2 m/s along it) touches, it does not hit."""
    _, monitor, _ = space_with((0.0, 0.0, 1.0, 0.0), (1.0, 0.49, 0.0, 0.0))
    monitor.run(120, DT)
    assert counts(monitor) == (1, 0, 0, 0)
    _, monitor, _ = space_with((0.0, 0.0, -1.0, 0.0), (0.6, 0.0, 1.0, 0.0))
    monitor.run(120, DT)
    assert counts(monitor) == (0, 0, 0, 0)


@pytest.mark.parametrize(("v", "impact"), [(0.1, False), (0.29, False), (0.3, True), (0.5, True)])
def test_a_robot_into_a_wall_is_counted_apart_from_robot_contacts(v, impact):
    """A wall's static body stands still: the closing speed is the robot's along the normal."""
    _, monitor, _ = space_with((0.0, 0.0, v, 0.0), wall_x=0.5)
    for _ in range(600):
        monitor.run(1, DT)
        if monitor.wall_hits:
            break
    assert counts(monitor) == (0, 0, 1, int(impact))


def test_every_contact_begun_counts_once_and_iterations_follow_the_contacts():
    """Two robots meet, are pulled apart, meet again: two contacts begun, each counted once
    however many steps it touches; ten solver iterations only while a contact touches, one
    otherwise; ``steps_touching`` the steps that ended touching."""
    space, monitor, (a, b) = space_with((0.0, 0.0, 0.2, 0.0), (0.6, 0.0, -0.2, 0.0))
    assert space.iterations == FREE_ITERATIONS
    seen = []
    for _ in range(2):
        step_until(monitor, lambda m: m.touching)
        assert space.iterations == CONTACT_ITERATIONS
        touching_steps = monitor.steps_touching
        monitor.run(5, DT)  # pressed together: still the one contact
        assert monitor.touching == 1 and monitor.steps_touching == touching_steps + 5
        a.velocity, b.velocity = (-0.5, 0.0), (0.5, 0.0)
        step_until(monitor, lambda m: not m.touching)
        assert space.iterations == FREE_ITERATIONS
        seen.append(counts(monitor))
        a.velocity, b.velocity = (0.2, 0.0), (-0.2, 0.0)
    assert seen == [(1, 1, 0, 0), (2, 2, 0, 0)]


def test_two_contacts_at_once_keep_ten_iterations_until_both_separate():
    """A robot pressed between two others: the iterations go back to one only when the last
    contact separates."""
    space, monitor, (a, _b, c) = space_with(
        (-0.6, 0.0, 0.1, 0.0), (0.0, 0.0, 0.0, 0.0), (0.6, 0.0, -0.1, 0.0)
    )
    step_until(monitor, lambda m: m.touching >= 2)
    a.velocity = (-0.5, 0.0)
    step_until(monitor, lambda m: m.touching != 2)
    assert monitor.touching == 1 and space.iterations == CONTACT_ITERATIONS
    c.velocity = (0.5, 0.0)
    step_until(monitor, lambda m: not m.touching)
    assert space.iterations == FREE_ITERATIONS and monitor.robot_hits == 2


def test_the_deepest_overlap_is_the_largest_penetration_after_any_step():
    """Two robots driven into each other harder and harder: ``max_overlap_m`` is the deepest
    penetration the geometry shows after any step (0.5 m less the centres' distance), and
    stays at that maximum once they separate."""
    _, monitor, (a, b) = space_with((0.0, 0.0, 0.3, 0.0), (0.6, 0.0, -0.3, 0.0))
    deepest = 0.0
    for _ in range(120):
        a.velocity, b.velocity = (1.0, 0.0), (-1.0, 0.0)  # pushed in every step
        monitor.run(1, DT)
        deepest = max(deepest, 2 * R - abs(b.position.x - a.position.x))
    assert deepest > 1e-3
    assert monitor.max_overlap_m == pytest.approx(deepest, rel=1e-9)
    a.velocity, b.velocity = (-1.0, 0.0), (1.0, 0.0)
    monitor.run(60, DT)
    assert monitor.touching == 0 and monitor.max_overlap_m == pytest.approx(deepest, rel=1e-9)


def test_many_contacts_at_once_read_their_depths_through_numpy_alike():
    """More than 16 contacts touching at once take the numpy path of ``_measure``: the same
    deepest overlap as the geometry, over a row of 24 robots pushed together."""
    n = 24
    robots = [(0.55 * k, 0.0, 0.0, 0.0) for k in range(n)]
    _, monitor, bodies = space_with(*robots)
    deepest = 0.0
    for _step in range(90):
        for k, body in enumerate(bodies):
            body.velocity = (0.4 * (n / 2 - k) / n * 4, 0.0)  # squeezed toward the middle
        monitor.run(1, DT)
        xs = np.sort([body.position.x for body in bodies])
        deepest = max(deepest, float((2 * R - np.diff(xs)).max()))
    assert monitor.touching > 16
    assert monitor.max_overlap_m == pytest.approx(deepest, rel=1e-9)


def test_counts_survive_a_checkpoint_round_trip_and_touching_starts_at_zero():
    _, monitor, _ = space_with((0.0, 0.0, 0.2, 0.0), (0.6, 0.0, -0.2, 0.0), wall_x=-0.4)
    step_until(monitor, lambda m: m.touching)
    monitor.run(3, DT)
    saved = monitor.state_arrays()
    assert {k: int(v) for k, v in saved.items() if k != "max_overlap_m"} == {
        "robot_hits": 1,
        "wall_hits": 0,
        "robot_impacts": 1,
        "wall_impacts": 0,
        "steps_touching": 4,
    }
    assert all(v.dtype == np.int64 for k, v in saved.items() if k != "max_overlap_m")
    assert float(saved["max_overlap_m"]) == monitor.max_overlap_m > 0.0
    fresh = ContactMonitor(pymunk.Space(), ROBOT, WALL)
    fresh.restore_arrays(saved)
    assert counts(fresh) == counts(monitor) and fresh.steps_touching == 4
    assert fresh.max_overlap_m == monitor.max_overlap_m and fresh.touching == 0


def test_each_wall_contact_counts_and_a_touch_after_an_impact_stays_an_impact_counted():
    """A robot hits a wall at 0.5 m/s, is pulled off, then touches it at 0.1 m/s: two wall
    contacts begun, one of them an impact, and no robot contact."""
    _, monitor, (a,) = space_with((0.0, 0.0, 0.5, 0.0), wall_x=0.5)
    step_until(monitor, lambda m: m.touching)
    a.velocity = (-0.5, 0.0)
    step_until(monitor, lambda m: not m.touching)
    assert counts(monitor) == (0, 0, 1, 1)
    a.velocity = (0.1, 0.0)
    step_until(monitor, lambda m: m.touching)
    assert counts(monitor) == (0, 0, 2, 1)
