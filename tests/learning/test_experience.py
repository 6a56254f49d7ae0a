"""TEP/TEM formulas against hand-computed values, behaviours and the coverage guard."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from learning.experience import B0_REGULAR, B1_EAGER_HESITANT, B2_REFUSED, ExperienceModel, tep
from sim.scenario import ExperienceSpec


@pytest.mark.parametrize(
    ("eta", "mu", "expected"),
    [
        (0, 0, 1.0),
        (1, 0, 2 / (1 + math.exp(-1))),  # 1.4621171572600098
        (0, 2, 2 / (1 + math.exp(2))),  # 0.2384058440442351
        (3, 1.5, 2 / (1 + math.exp(-1.5))),
    ],
)
def test_tep_matches_equation_5(eta, mu, expected):
    assert float(tep(eta, mu)) == pytest.approx(expected, rel=1e-15)


def test_tep_is_stable_for_huge_differences():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow in exp would raise here
        big = tep(np.array([900.0, 0.0, 1e6]), np.array([0.0, 900.0, 0.0]))
    assert big[0] == 2.0 and big[2] == 2.0
    assert 0.0 <= big[1] < 1e-300
    assert np.isfinite(big).all()


def test_tem_is_the_mean_of_tep_per_auction_bid():
    # Two robots bid in three T0 auctions: R0 wins the first, R1 the next two.
    exp = ExperienceModel(np.ones((2, 1), dtype=bool), ExperienceSpec(delta_u=0.0))
    assert exp.u_[0, 0] == 1.0  # u = 1 before any auction
    both = np.array([0, 1])
    for winner in (0, 1, 1):
        exp.observe_auction(0, both, winner)
    # R0: (eta, mu) = (1, .5), (1, 1), (1, 1.5); R1: (0, .5), (1, 1), (2, 1.5)
    v0 = [2 / (1 + math.exp(-0.5)), 1.0, 2 / (1 + math.exp(0.5))]
    v1 = [2 / (1 + math.exp(0.5)), 1.0, 2 / (1 + math.exp(-0.5))]
    assert exp.u_[0, 0] == pytest.approx(sum(v0) / 3, rel=1e-15)
    assert exp.u_[1, 0] == pytest.approx(sum(v1) / 3, rel=1e-15)
    assert exp.eta_.ravel().tolist() == [1.0, 2.0]
    assert exp.mu_.ravel().tolist() == [1.5, 1.5]
    assert exp.v_.ravel().tolist() == pytest.approx([v0[-1], v1[-1]], rel=1e-15)  # the last v


def test_mu_adds_one_over_number_of_bidders_only_for_bidders():
    exp = ExperienceModel(np.ones((4, 1), dtype=bool), ExperienceSpec())
    exp.observe_auction(0, np.array([0, 2, 3]), 2)
    assert exp.mu_.ravel().tolist() == pytest.approx([1 / 3, 0.0, 1 / 3, 1 / 3])
    assert exp.count_.ravel().tolist() == [1, 0, 1, 1]
    assert exp.count_.dtype == np.int64 and exp.behaviour_.dtype == np.int8  # counts, codes


def test_behaviour_one_starts_at_delta_v_inclusive():
    # v after one lost auction alone: eta - mu = -1 -> v = 0.5378828427399902, |v - 1| = 0.462...
    v = float(tep(0, 1))
    for delta_v, expected in ((abs(v - 1), B1_EAGER_HESITANT), (abs(v - 1) + 1e-9, B0_REGULAR)):
        exp = ExperienceModel(np.ones((1, 1), dtype=bool), ExperienceSpec(delta_v=delta_v))
        exp.observe_auction(0, np.array([0]), -1)
        assert exp.behaviour_[0, 0] == expected


def test_bid_scale_is_tem_in_behaviour_one_only():
    exp = ExperienceModel(np.ones((2, 1), dtype=bool), ExperienceSpec(delta_v=0.1))
    exp.observe_auction(0, np.array([0]), -1)  # R0 loses alone: v = 0.5379, B1
    scale = exp.bid_scale()
    assert scale[0, 0] == pytest.approx(float(tep(0, 1)))
    assert scale[1, 0] == 1.0


def test_refusal_needs_n_min_observations_and_low_tem():
    spec = ExperienceSpec(delta_u=0.7, n_min=3, coverage_k=1)
    exp = ExperienceModel(np.ones((2, 2), dtype=bool), spec)  # type 1 keeps both in the team
    for _ in range(2):
        exp.observe_auction(0, np.array([0, 1]), 1)
    assert exp.u_[0, 0] < 0.7  # (0.755 + 0.538) / 2 = 0.646
    assert exp.refusals() == []  # only two observations
    exp.observe_auction(0, np.array([0, 1]), 1)
    assert exp.refusals() == [(0, 0)]
    assert exp.behaviour_[0, 0] == B2_REFUSED
    assert not exp.willing_[0, 0] and exp.willing_[1, 0]


def test_coverage_guard_keeps_k_willing_robots_and_drops_least_experienced_first():
    spec = ExperienceSpec(delta_u=1.5, n_min=1, coverage_k=2)  # everyone is due at once
    exp = ExperienceModel(np.ones((4, 2), dtype=bool), spec)
    exp.observe_auction(0, np.array([0, 1, 2, 3]), 3)
    exp.observe_auction(0, np.array([0, 1, 2]), 2)
    exp.observe_auction(0, np.array([0, 1]), 1)
    refused = exp.refusals()
    assert len(refused) == 2
    assert exp.willing_[:, 0].sum() == 2
    assert {j for j, _ in refused} == {0, 1}  # R0 and R1 have the lowest TEM


def test_a_robot_never_refuses_its_last_type():
    """R0 can do only type 0; R1 can do 0 and 1. Both are due to refuse type 0."""
    spec = ExperienceSpec(delta_u=1.5, n_min=1, coverage_k=1)
    capable = np.array([[True, False], [True, True], [True, False]])
    exp = ExperienceModel(capable, spec)
    exp.observe_auction(0, np.array([0, 1, 2]), 2)  # R2 wins: R0 and R1 fall below 1
    assert exp.u_[0, 0] < 1.5 and exp.u_[1, 0] < 1.5
    assert exp.refusals() == [(1, 0)]  # R0 would be left with nothing: it keeps type 0
    assert exp.willing_[0].tolist() == [True, False]
    assert exp.willing_[1].tolist() == [False, True]


def test_refusal_is_strictly_below_delta_u_eq_10():
    spec = ExperienceSpec(delta_u=0.5, n_min=2, coverage_k=1)
    exp = ExperienceModel(np.ones((3, 2), dtype=bool), spec)
    exp.count_[:, 0] = 2
    exp.v_sum_[:, 0] = [1.0, 0.999, 2.0]  # TEM exactly delta_u, just below it, and 1
    assert exp.refusals() == [(1, 0)]


def test_willing_is_a_boolean_mask_even_from_a_0_1_capability_matrix():
    exp = ExperienceModel(np.array([[1, 0], [1, 1]]), ExperienceSpec())
    robots = np.array([10, 11])
    assert robots[exp.willing_[:, 1]].tolist() == [11]
    assert robots[exp.willing_[:, 0]].tolist() == [10, 11]


def test_without_sticky_b1_a_robot_goes_back_to_regular_and_refusal_stays():
    """R0 and R1 bid for type 0 (R1 wins), then R0 wins twice and its v comes back near 1."""
    spec = ExperienceSpec(delta_v=0.2, sticky_b1=False)
    exp = ExperienceModel(np.ones((3, 1), dtype=bool), spec)
    exp.behaviour_[2, 0] = B2_REFUSED
    both = np.array([0, 1, 2])
    exp.observe_auction(0, both, 1)  # eta - mu: R0 -1/3, R1 +2/3: |v - 1| 0.165, 0.322
    assert exp.behaviour_[:, 0].tolist() == [B0_REGULAR, B1_EAGER_HESITANT, B2_REFUSED]
    exp.observe_auction(0, both, 0)  # R0 1 - 2/3 = 1/3, R1 1 - 2/3 = 1/3: |v - 1| 0.165 both
    assert exp.behaviour_[:, 0].tolist() == [B0_REGULAR, B0_REGULAR, B2_REFUSED]
    exp.observe_auction(0, both, 1)  # R0 1 - 1 = 0, R1 2 - 1 = 1: |v - 1| 0, 0.462
    assert exp.behaviour_[:, 0].tolist() == [B0_REGULAR, B1_EAGER_HESITANT, B2_REFUSED]
    with_sticky = ExperienceModel(np.ones((3, 1), dtype=bool), ExperienceSpec(delta_v=0.2))
    for winner in (1, 0):
        with_sticky.observe_auction(0, both, winner)
    assert with_sticky.behaviour_[1, 0] == B1_EAGER_HESITANT  # sticky: stays in behaviour 1


@pytest.mark.parametrize("sticky", [True, False])
@pytest.mark.parametrize("delta_v", [0.05, 0.2])
def test_replay_is_observe_auction_without_changing_the_model(sticky, delta_v):
    """``replay`` (used to withhold the experience of an abandoned win) must give, for one
    robot and type, exactly what ``observe_auction`` gives for the same auctions; random
    sequences of auctions (seeded), robot 0 bidding in each with 1-4 others."""
    rng = np.random.default_rng(17)
    spec = ExperienceSpec(delta_v=delta_v, sticky_b1=sticky)
    for _ in range(30):
        live = ExperienceModel(np.ones((5, 2), dtype=bool), spec)
        for _ in range(int(rng.integers(0, 6))):  # some history first, on both types
            live.observe_auction(int(rng.integers(2)), np.arange(int(rng.integers(1, 6))), 0)
        if not sticky and rng.random() < 0.3:
            live.behaviour_[0, 1] = 2  # refused: replay keeps it, as observe_auction does
        before = live.robot_state(0, 1)
        auctions = []
        for _ in range(int(rng.integers(1, 8))):
            n = int(rng.integers(1, 6))
            won = bool(rng.random() < 0.5)
            auctions.append((n, won))
        kept = [np.copy(a) for a in (live.eta_, live.mu_, live.v_, live.v_sum_, live.count_)]
        got = live.replay(before, auctions)
        after = [live.eta_, live.mu_, live.v_, live.v_sum_, live.count_]
        assert all(np.array_equal(a, b) for a, b in zip(kept, after, strict=True))
        for n, won in auctions:
            live.observe_auction(1, np.arange(n), 0 if won else -1)  # robot 0 won, or nobody
        want = live.robot_state(0, 1)
        assert [float(x) for x in got] == [float(x) for x in want]


def test_replay_knows_at_exactly_delta_v():
    """Eq. (10)'s boundary in replay as in observe_auction: |v - 1| equal to delta_v counts."""
    v = float(tep(np.array([1.0]), np.array([0.5]))[0])  # one auction of 2 bidders, won
    exp = ExperienceModel(np.ones((1, 1), dtype=bool), ExperienceSpec(delta_v=abs(v - 1.0)))
    got = exp.replay(exp.robot_state(0, 0), [(2, True)])
    assert got[2] == v and got[5] == B1_EAGER_HESITANT
