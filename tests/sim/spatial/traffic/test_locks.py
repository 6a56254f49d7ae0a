"""``sim.spatial.traffic.locks.Locks``: directional locks, first come first served, a chain at
once, the direction turning after the opposing wait."""

from __future__ import annotations

from sim.spatial.traffic.locks import Locks

UP, DOWN = 1, -1


def always(_j: int) -> bool:
    return True


def test_first_come_first_served_on_an_empty_passage():
    locks = Locks(turn_s=10.0)
    locks.request(2, ((0, DOWN),), 1.0)
    locks.request(1, ((0, UP),), 0.5)  # asked earlier
    assert locks.grant(1.0, always) == [1]
    assert locks.occupants == {0: {1: UP}}
    assert list(locks.requests) == [2]
    assert locks.grant(1.1, always) == []  # used the other way


def test_robots_follow_one_another_the_way_a_passage_is_used():
    locks = Locks(turn_s=10.0)
    locks.request(0, ((0, UP),), 0.0)
    assert locks.grant(0.0, always) == [0]
    locks.request(5, ((0, DOWN),), 1.0)
    locks.request(3, ((0, UP),), 2.0)
    assert locks.grant(2.0, always) == [3]  # follows 0 up; 5 waits
    assert locks.occupants[0] == {0: UP, 3: UP}


def test_after_turn_s_of_opposing_wait_no_one_more_enters_and_the_passage_turns():
    locks = Locks(turn_s=10.0)
    locks.request(0, ((0, UP),), 0.0)
    locks.grant(0.0, always)
    locks.request(5, ((0, DOWN),), 1.0)
    locks.request(3, ((0, UP),), 11.0)
    assert locks.grant(11.0, always) == []  # 5 has waited 10 s: 3 may not follow
    assert locks.turns_forced == 1
    locks.release(0, [0])
    assert locks.grant(11.5, always) == [5]  # empty: the oldest, down
    assert locks.turns == 1
    assert locks.grant(11.6, always) == []  # 3 waits for the turn back


def test_a_chain_is_granted_whole_or_not_at_all():
    locks = Locks(turn_s=10.0)
    locks.force(7, ((1, DOWN),))
    locks.request(0, ((0, UP), (1, UP)), 0.0)
    assert locks.grant(0.0, always) == []
    assert 0 not in locks.occupants.get(0, {})  # no part of it held meanwhile
    locks.release(7, [1])
    assert locks.grant(1.0, always) == [0]
    assert locks.held_by(0) == {0, 1}


def test_a_robot_not_ready_does_not_claim_and_an_older_ready_one_does():
    locks = Locks(turn_s=10.0)
    locks.request(0, ((0, UP),), 0.0)  # oldest, but its way beyond the exit is blocked
    locks.request(1, ((0, DOWN),), 1.0)
    assert locks.grant(1.0, lambda j: j != 0) == [1]
    locks.release_all(1)
    locks.request(2, ((0, DOWN),), 2.0)
    locks.request(3, ((1, UP), (0, UP)), 0.5)  # ready, older, but passage 1 is taken
    locks.force(9, ((1, DOWN),))
    assert locks.grant(2.0, lambda j: j != 0) == []  # 3 claims 0 up: 2 may not overtake
    assert set(locks.requests) == {0, 2, 3}


def test_a_request_keeps_its_place_when_its_chain_changes_but_shares_a_passage():
    locks = Locks(turn_s=10.0)
    locks.request(0, ((0, UP),), 1.0)
    locks.request(0, ((0, UP), (1, UP)), 3.0)
    assert locks.requests[0].since_s == 1.0
    locks.request(0, ((4, UP),), 5.0)
    assert locks.requests[0].since_s == 5.0


def test_force_holds_against_everyone_and_release_all_frees():
    locks = Locks(turn_s=10.0)
    locks.request(1, ((0, UP),), 0.0)
    locks.force(2, ((0, DOWN),))
    assert locks.forced == 1
    assert locks.grant(0.0, always) == []
    locks.release_all(2)
    assert locks.occupants == {}
    assert locks.grant(0.1, always) == [1]
    assert locks.counts() == {"grants": 1, "forced": 1, "turns": 0, "turns_forced": 0}
