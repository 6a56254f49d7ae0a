"""``scenarios.bench.calibration``: the fixed physics step the bench measures loops in, and the
same step timed in turns beside the loops (a fake clock here)."""

from __future__ import annotations

import pytest

from scenarios.bench.calibration import calibration_space, calibration_while


def test_the_calibration_space_is_built_the_same_every_time_and_never_touches():
    a, b = calibration_space(9), calibration_space(9)
    assert [tuple(x.position) for x in a.bodies] == [tuple(x.position) for x in b.bodies]
    for _ in range(60):
        a.step(1.0 / 60.0)
    touching = []
    for shape in a.shapes:
        touching += [hit for hit in a.shape_query(shape) if hit.shape.body is not shape.body]
    assert not [hit for hit in touching if hit.shape.body.body_type == hit.shape.body.DYNAMIC]


@pytest.mark.parametrize(("answers", "chunks"), [([True, True, False], 3), ([False], 1)])
def test_calibration_in_turns_steps_until_told_to_stop_and_divides_its_time_by_its_steps(
    answers, chunks
):
    """A chunk of 4 steps, then a tick, then ``more()``: at least one chunk. The fake clock
    reads 10 s at the start and 10 s more at the end."""
    answers = iter(answers)
    ticks = []
    times = iter([10.0, 20.0])
    got = calibration_while(
        4, lambda: next(answers), lambda: ticks.append(1), lambda: next(times), chunk=4
    )
    assert len(ticks) == chunks
    assert got == pytest.approx(10.0 / (4 * chunks))
