"""The traffic rules for single-lane passages (``[spatial.traffic] rules = "on"``) in whole
runs on hand-built arenas: who enters first, who holds where, never two robots in a passage
against each other's direction, no deadlock; and on the bundled warehouse. The rules' parts
one by one are in ``tests/sim/spatial/traffic/``.

Robots of radius 0.25 m at 1.5 m/s (the bundled scenarios' drive); ORCA on.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenarios.experiments.hardcases import LOOK_AHEAD_DEFAULT, run_case
from scenarios.experiments.protocol import RunSpec, execute
from sim.scenario import DriveSpec
from sim.scenario.spatial import TrafficSpec
from sim.states import DRIVING, WAITING, WORKING, shown_states
from tests.worlds import swap_world

ON = {"traffic": TrafficSpec(rules="on")}
OFF = {"traffic": TrafficSpec(rules="off")}
# shelf rows at y 7..8 with a 1 m gap at x 9.5..10.5; closed rows at y 4..5 and 10..11
ONE_GAP = (
    ((3.0, 7.0), (9.5, 7.0), (9.5, 8.0), (3.0, 8.0)),
    ((10.5, 7.0), (17.0, 7.0), (17.0, 8.0), (10.5, 8.0)),
    ((3.0, 4.0), (17.0, 4.0), (17.0, 5.0), (3.0, 5.0)),
    ((3.0, 10.0), (17.0, 10.0), (17.0, 11.0), (3.0, 11.0)),
)
# two 1 m gaps in a row 1 m apart (x 9.5..10.5 at y 6..7 and 8..9)
TWO_GAPS = (
    ((3.0, 6.0), (9.5, 6.0), (9.5, 7.0), (3.0, 7.0)),
    ((10.5, 6.0), (17.0, 6.0), (17.0, 7.0), (10.5, 7.0)),
    ((3.0, 8.0), (9.5, 8.0), (9.5, 9.0), (3.0, 9.0)),
    ((10.5, 8.0), (17.0, 8.0), (17.0, 9.0), (10.5, 9.0)),
)
AISLE = (  # a 2 m aisle along y 5..7
    ((1.0, 4.0), (15.0, 4.0), (15.0, 5.0), (1.0, 5.0)),
    ((1.0, 7.0), (15.0, 7.0), (15.0, 8.0), (1.0, 8.0)),
)


def world(
    starts,
    goals,
    obstacles,
    settings,
    control="scalar",
    size=(20.0, 15.0),
    look_ahead=LOOK_AHEAD_DEFAULT,
):
    return swap_world(
        starts,
        goals,
        size,
        control,
        look_ahead=look_ahead,
        obstacles=obstacles,
        drive=DriveSpec(),
        settings={**settings, "stuck_timeout_s": 6.0},
    )


def against_each_other(w) -> bool:
    """True if two robots' centres are in one passage, crossing it opposite ways (by their
    headings along its axis)."""
    tr = w.jobs.traffic
    z, th = w.fleet.last_z_m, np.exp(1j * w.fleet.last_th_rad)
    for p in tr.map.passages.values():
        inside = [j for j in range(len(z)) if p.holds(complex(z[j]), 0.0, 0.0)]
        ways = {
            np.sign((th[j] * np.conj(p.axis)).real) for j in inside if w.fleet.state[j] == DRIVING
        }
        if len(ways) > 1:
            return True
    return False


def run(w, limit_s, each=None) -> float:
    """Advance until no robot drives (the time) or ``limit_s`` (inf), calling ``each(w)``."""
    while w.time_s < limit_s:
        w.advance(0.1)
        if each is not None:
            each(w)
        if not (w.fleet.state == DRIVING).any():
            return w.time_s
    return np.inf


@pytest.mark.parametrize("control", ["scalar", "array"])
def test_one_gap_the_robot_that_asks_first_goes_and_the_other_holds_aside(control):
    """Robots 1 m from either mouth of a 1 m gap, each going through it. Both ask at once;
    robot 0 (the lower index) goes first. Robot 1 holds 0.6 m before its mouth, 0.7 m to the
    right of its way (going down, right is -x), drawn as waiting with its stuck clock
    stopped; it goes once robot 0 is past. Never are both in the gap; no contact; both are
    through sooner than the jam rules alone get them through."""
    starts, goals = [(10.0, 6.0), (10.0, 9.0)], [(10.0, 9.0), (10.0, 6.0)]
    w = world(starts, goals, ONE_GAP, ON, control)
    tr = w.jobs.traffic
    w.advance(0.1)
    assert tr.locks.occupants == {0: {0: 1}}
    assert w.jobs.held.tolist() == [False, True]
    assert tr.hold_at[1] == pytest.approx(9.3 + 8.6j)
    seen = {"waiting": 0, "both": 0}

    def each(w):
        shown = shown_states(w.fleet.state, w.fleet.t_progress_s, w.time_s)
        seen["waiting"] += w.jobs.held[1] and shown[1] == WAITING
        seen["both"] += against_each_other(w)

    t_on = run(w, 60.0, each)
    assert seen["both"] == 0 and seen["waiting"] > 10
    assert w.contacts.robot_hits == 0 and w.jobs.failures == 0
    s = w.summary()
    assert (s["traffic_grants"], s["traffic_holds"]) == (2, 1)
    t_off = run(world(starts, goals, ONE_GAP, OFF, control), 60.0)
    assert t_on < t_off


def test_a_chain_of_two_gaps_is_taken_at_once_and_freed_gap_by_gap():
    """Two gaps 1 m apart, the 1 m aisle between them no place to hold: one chain. Robot 0
    goes up through both, robot 1 down through both; both ask at once, robot 0 gets the
    chain (both gaps) and robot 1 holds above it. Robot 0 frees the lower gap once its centre
    is a radius and 0.1 m past it, while it still holds the upper one; robot 1 goes once the
    upper one is free, and never are the two in a gap against each other."""
    starts, goals = [(10.0, 5.0), (10.0, 10.2)], [(10.0, 10.2), (10.0, 5.0)]
    w = world(starts, goals, TWO_GAPS, ON)
    tr = w.jobs.traffic
    lower, upper = (k for k, p in tr.map.passages.items() if abs(p.centre.real - 10.0) < 1e-9)
    assert tr.map.passages[lower].centre.imag < tr.map.passages[upper].centre.imag
    w.advance(0.1)
    assert [c.passages for c in tr.chains[0]] == [((lower, 1), (upper, 1))]
    assert tr.locks.held_by(0) == {lower, upper}
    assert w.jobs.held.tolist() == [False, True]
    freed_lower = []

    def each(w):
        if tr.locks.held_by(0) == {upper}:
            freed_lower.append(w.fleet.last_z_m[0].imag)
        assert not against_each_other(w)

    assert run(w, 60.0, each) < 60.0
    assert freed_lower and min(freed_lower) >= 7.0 + 0.25 + 0.1 - 1e-9
    assert w.contacts.robot_hits == 0 and w.jobs.failures == 0


@pytest.mark.parametrize("look_ahead", ["off", "on"])
def test_a_robot_at_work_in_an_aisle_is_passed_in_the_lane_beside_it_one_way_at_a_time(
    look_ahead,
):
    """A robot at work in the middle of a 2 m aisle leaves a lane each side: a temporary
    passage across the aisle. Robots from both ends plan their ways round it (through the
    lane beside it) and pass it one at a time; both get through without a contact, within
    25 s when they plan as if it were not there. Planning round it (``look_ahead``, the robot
    at work grown by ``ahead_grow_m``) takes a wider way: both are through at 25.3 s."""
    starts = [(8.0, 6.0), (2.0, 6.0), (14.0, 6.0)]
    goals = [(8.0, 6.0), (14.0, 6.0), (2.0, 6.0)]
    w = world(starts, goals, AISLE, ON, size=(16.0, 12.0), look_ahead=look_ahead)
    w.advance(0.2)
    tr = w.jobs.traffic
    assert w.fleet.state[0] == WORKING
    temp = tr.map.passages[tr.map.n_static + 0]
    assert temp.passable and temp.centre == pytest.approx(8 + 6j)
    done = {}

    def each(w):
        for j in (1, 2):
            if w.fleet.state[j] != DRIVING:
                done.setdefault(j, w.time_s)
        assert not against_each_other(w)

    assert run(w, 60.0, each) < 60.0  # 1 and 2 at work at their goals, 0 still at work
    assert set(done) == {1, 2}
    if look_ahead == "off":
        assert max(done.values()) < 25.0
    assert w.summary()["traffic_round"] >= 2
    assert w.contacts.robot_hits == 0 and w.jobs.failures == 0


def test_the_corridor_hard_case_is_quicker_with_the_rules():
    """Two robots swap ends of a 0.75 m corridor: without the rules they meet inside and one
    backs out (23.1 s); with them the second holds before its mouth."""
    off = run_case("corridor", settings=OFF)
    on = run_case("corridor", settings=ON)
    assert on["robot_touch"] == on["robot_impact"] == 0 and on["failed"] == 0
    assert on["time_s"] < off["time_s"] - 5.0


def test_rules_off_or_no_avoidance_add_nothing():
    for settings, avoidance in ((OFF, "orca"), (ON, "none")):
        w = swap_world(
            [(10.0, 5.6)],
            [(10.0, 9.4)],
            (20.0, 15.0),
            "scalar",
            avoidance,
            obstacles=ONE_GAP,
            settings=settings,
        )
        assert w.jobs.traffic is None
        assert not any(k.startswith("traffic_") for k in w.summary())


@pytest.mark.slow
def test_the_warehouse_with_the_rules_finds_its_gaps_and_fails_no_task():
    """The bundled warehouse, a short stream: its five cross-aisle gaps are the passages,
    robots take them under the locks and hold before them, and the counts reach metrics."""
    short = (
        ("stream.n_sets", 3),
        ("stream.rounds_per_set", 8),
        ("stream.learn_sets", 2),
        ("stream.test_sets", 1),
        ("spatial.traffic.rules", "on"),
    )
    out = execute(RunSpec("warehouse", "market", "abstract", 0, short))
    sp = out["spatial"]
    assert sp["traffic_passages"] == 5
    assert sp["traffic_grants"] > 0 and sp["traffic_temporary"] > 0
    assert sp["failed_tasks"] == 0
    assert sp["contacts_robot_impact"] == 0


def test_a_robot_beginning_work_reannotates_only_the_ways_that_pass_near_it():
    """Robot 0 begins work in the middle of a 2 m aisle (a temporary passage across it).
    In that control period robot 1, whose way runs along the aisle past it, is annotated
    again (and then carries the new passage); robot 2, driving 12 m away on open floor, is
    not: its way is farther than ``PassageMap.reach_m`` from robot 0."""
    starts = [(6.0, 6.0), (14.0, 6.0), (20.0, 2.0)]
    goals = [(8.0, 6.0), (2.0, 6.0), (28.0, 10.0)]
    w = world(starts, goals, AISLE, ON, size=(30.0, 12.0))
    tr = w.jobs.traffic
    calls = []
    plain = tr.annotate
    tr.annotate = lambda j, t, round_workers=True: (calls.append(j), plain(j, t, round_workers))
    while w.fleet.state[0] != WORKING:
        calls.clear()
        w.advance(0.1)
        assert w.time_s < 5.0
    assert (w.fleet.state[1:] == DRIVING).all()
    assert tr.map.passages[tr.map.n_static + 0].centre == pytest.approx(8 + 6j, abs=0.1)
    assert 1 in calls and 2 not in calls
    assert tr.map.reach_m < 12.0
    assert any(tr.map.n_static + 0 in c.keys for c in tr.chains[1])


@pytest.mark.parametrize("case", ["one_gap", "aisle"])
def test_the_shortcut_for_a_quiet_period_changes_nothing(case, monkeypatch):
    """A control period in which nothing the rules follow changed returns at once
    (``Traffic._still``, on the states as bytes; else ``Traffic._quiet``); the same runs with
    every period taken in full are bit-identical, and whenever the quick test says still, the
    full one says quiet. The robots the rules follow are those with a chain ahead, a lock, a
    request or a hold, found from the robots given chains (``Traffic.chained``) as from all;
    those with a new path, found among the robots given one since (``PathFollower.sets_``), as
    from the whole fleet's signatures (compared as arrays and one by one)."""
    from sim.spatial.traffic.rules import Traffic

    still, active, agreed, chained = Traffic._still, Traffic._active, [], []
    new_paths, renewed = Traffic._new_paths, []

    def slowly(self) -> np.ndarray:
        out = self.held.copy()
        out[[j for j, c in enumerate(self.chains) if c]] = True
        for occ in self.locks.occupants.values():
            out[list(occ)] = True
        out[list(self.locks.requests)] = True
        return out

    def active_checked(self) -> list[int]:
        out = active(self)
        assert out == slowly(self).nonzero()[0].tolist()
        chained.append(any(self.chains))
        return out

    def new_paths_checked(self) -> list[int]:
        fol = self.follower
        end = fol.points[np.arange(len(fol.last)), np.maximum(fol.last, 0)]
        sig = np.stack([fol.points[:, 0], end, fol.last.astype(complex), fol.after_m[:, 0]])
        looked = int((fol.sets_ != self.sig_sets).sum())
        few = 0 if len(renewed) % 2 else 2  # alternately as arrays and (up to 2) one by one
        out = new_paths(self, few=few)
        assert out == (sig != self.sig).any(axis=0).nonzero()[0].tolist()
        assert np.array_equal(self.sig_sets, fol.sets_)
        renewed.append(looked)
        return out

    def checked(self) -> bool:
        locks = self.locks
        none = not (locks.occupants or locks.requests or self.held.any() or any(self.chains))
        assert self._follow_none() == none
        out = still(self)
        if out:
            work = self.fleet.state == WORKING
            assert not (work != self.working).any()
            assert self._quiet(self.fleet.state == DRIVING)
            agreed.append(self.fleet.state.copy())
        return out

    def trace():
        if case == "one_gap":
            w = world([(10.0, 6.0), (10.0, 9.0)], [(10.0, 9.0), (10.0, 6.0)], ONE_GAP, ON)
        else:
            starts = [(8.0, 6.0), (2.0, 6.0), (14.0, 6.0)]
            goals = [(8.0, 6.0), (14.0, 6.0), (2.0, 6.0)]
            w = world(starts, goals, AISLE, ON, size=(16.0, 12.0))
        out = []
        while w.time_s < 30.0:
            w.advance(0.1)
            out.append(w.fleet.last_z_m.copy())
        return np.array(out), w.summary()

    with monkeypatch.context() as m:
        m.setattr(Traffic, "_still", checked)
        m.setattr(Traffic, "_active", active_checked)
        m.setattr(Traffic, "_new_paths", new_paths_checked)
        quick, quick_summary = trace()
    with monkeypatch.context() as m:
        m.setattr(Traffic, "_still", lambda self: False)
        m.setattr(Traffic, "_quiet", lambda self, drive: False)
        full, full_summary = trace()
    assert np.array_equal(quick, full)
    assert quick_summary == full_summary
    assert quick_summary["traffic_grants"] >= 2
    assert len(agreed) >= 10  # the quick test was taken, with robots driving and at work
    assert any((s == DRIVING).any() for s in agreed) and any((s == WORKING).any() for s in agreed)
    assert any(chained) and not all(chained)
    assert any(renewed) and not all(renewed)  # robots looked at again, and periods with none
    assert any(renewed[0::2]) and any(renewed[1::2])  # by both ways


def test_a_robot_kept_out_at_the_mouth_holds_off_the_lane_round_it():
    """Robot 1 stands 0.45 m above the gap's mouth, robots at work on either side of its way
    (0.8 m left and right, 0.45 m higher): no holding point lies on its way before the mouth,
    so it holds at the first free point round it (``PassageMap.spot_near``) instead of in the
    lane out of the mouth, where it stood in robot 0's way out (both through at 32.3 s then,
    by the jam rules). The point keeps a pass off that lane; both are through by 15 s, one at
    a time, without a contact."""
    starts = [(10.0, 6.0), (10.0, 8.45), (9.2, 8.9), (10.8, 8.9)]
    goals = [(10.0, 9.5), (10.0, 6.0), (9.2, 8.9), (10.8, 8.9)]
    w = world(starts, goals, ONE_GAP, ON)
    tr = w.jobs.traffic
    w.advance(0.1)
    assert tr.locks.occupants == {0: {0: 1}} and w.jobs.held.tolist() == [False, True, False, False]
    spot = complex(tr.hold_at[1])
    assert tr.counts["spot_near"] == 1 and abs(spot - (10 + 8.45j)) > 0.5
    # off the lane out of the gap's upper mouth (x = 10, y 8 to 10) by a pass
    lane = abs(spot - complex(10.0, min(max(spot.imag, 8.0), 10.0)))
    assert lane >= tr.map.pass_m
    chain, keep = tr.chains[1][0], tr.near_m + 0.1
    other = tr.map.spot_near(10 + 8.45j, chain, np.array([spot]), keep)  # one held there now
    assert other is not None and abs(other - spot) >= keep
    crowd = (np.arange(0.0, 20.0, 0.5)[:, None] + 1j * np.arange(0.0, 15.0, 0.5)[None, :]).ravel()
    assert tr.map.spot_near(10 + 8.45j, chain, crowd, keep) is None  # then it holds where it is
    seen = {"both": 0}

    def each(w):
        seen["both"] += against_each_other(w)

    assert run(w, 60.0, each) < 15.0
    assert seen["both"] == 0 and w.contacts.robot_hits == 0 and w.jobs.failures == 0
    assert w.summary()["traffic_spot_near"] == 1


def test_a_path_given_in_a_still_period_is_annotated():
    """The quick test for a quiet period (``Traffic._still``) looks at the robots' states only:
    a driving robot given a new path while every state stays as it was is still annotated,
    because the follower's count of paths set changed."""
    from sim.spatial.traffic.rules import Traffic

    starts = [(8.0, 6.0), (2.0, 6.0), (14.0, 6.0)]
    goals = [(8.0, 6.0), (14.0, 6.0), (2.0, 6.0)]
    w = world(starts, goals, AISLE, ON, size=(16.0, 12.0))
    tr = w.jobs.traffic
    while not (Traffic._still(tr) and (w.fleet.state == DRIVING).any()):
        w.advance(0.1)
        assert w.time_s < 30.0
    j = int((w.fleet.state == DRIVING).nonzero()[0][0])
    calls = []
    plain = tr.annotate
    tr.annotate = lambda k, t, round_workers=True: (calls.append(k), plain(k, t, round_workers))
    tr.period(w.time_s)
    assert calls == []  # nothing changed: the period returned at once
    z = complex(w.fleet.last_z_m[j])
    w.jobs.follower.set_path(j, np.array([[z.real, z.imag], [z.real, z.imag + 1.0]]))
    tr.period(w.time_s)
    assert calls == [j]
