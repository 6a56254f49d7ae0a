"""The site queue in a whole run: 30 robots sent to one site all work there, a few at a time,
without a contact. The queue's rules one by one are in ``tests/sim/spatial/test_sites.py``."""

from __future__ import annotations

import numpy as np
import pytest

from sim.states import WORKING
from tests.worlds import circle, swap_world


@pytest.mark.slow
@pytest.mark.parametrize("control", ["scalar", "array"])
def test_thirty_robots_sent_to_one_site_all_work_there_within_90_s_without_a_contact(control):
    """The issue's hard case: 30 robots on an 8 m circle all sent to its centre with 2 s of
    work each; the site's queue lets them in five at a time (measured 61-71 s)."""
    n, centre = 30, (10.0, 10.0)
    starts, _ = circle(n, 8.0, centre)
    world = swap_world(starts, [centre] * n, (20.0, 20.0), control)
    world.jobs.exec_time_s[:] = 2.0
    worked = np.zeros(n, dtype=bool)
    while world.time_s < 90.0 and not worked.all():
        world.advance(0.1)
        worked |= world.fleet.state == WORKING
    assert worked.all(), f"{int((~worked).sum())} robots never worked within 90 s"
    assert world.contacts.robot_hits == 0 and world.contacts.wall_hits == 0
    assert world.jobs.failures == 0
