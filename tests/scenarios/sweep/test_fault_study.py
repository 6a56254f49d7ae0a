"""The fault study (``scenarios.sweep.fault_study``): its sweep file and its loss, paired by
seed."""

from __future__ import annotations

import math

import pytest

from scenarios.sweep.fault_study import analyse, markdown
from scenarios.sweep.spec import load_sweep


def test_fault_sweep_file_is_valid_and_has_the_no_fault_reference():
    sweep = load_sweep("faults")
    assert sweep.parameters == ("faults.mttf_s",)
    values = [c[0] for c in sweep.combos]
    assert math.inf in values and len(sweep.seeds) == 5
    assert set(sweep.allocators) == {"market", "ql", "expt", "greedy", "cbba"}


def row(alloc, seed, mttf, c_all, c_high, scarce_high, avail=None, abandoned=None):
    return {"allocator": alloc, "seed": seed, "faults.mttf_s": mttf, "completion_all": c_all,
            "completion_high": c_high, "completion_scarce_high": scarce_high,
            "availability": avail, "abandoned": abandoned, "scarce_types": "T1"}  # fmt: skip


def test_fault_study_loss_is_paired_by_seed():
    rows = [
        row("market", 0, math.inf, 0.8, 0.9, 0.5),
        row("market", 1, math.inf, 0.6, 0.7, 0.4),
        row("market", 0, 500.0, 0.6, 0.9, 0.25, 0.9, 10),
        row("market", 1, 500.0, 0.3, 0.7, 0.3, 0.8, 20),
    ]
    doc = analyse(rows)
    assert doc["mttf_s"] == [None, 500.0]
    ref, hit = doc["table"]
    assert ref["loss_completion_all"]["mean"] == 0.0
    # seed 0 loses 1 - 0.6/0.8 = 25 %, seed 1 loses 1 - 0.3/0.6 = 50 %: mean 37.5 %
    assert hit["loss_completion_all"]["mean"] == pytest.approx(0.375)
    assert hit["loss_completion_high"]["mean"] == pytest.approx(0.0)
    assert hit["loss_completion_scarce_high"]["mean"] == pytest.approx((0.5 + 0.25) / 2)
    assert hit["availability"]["mean"] == pytest.approx(0.85)
    table = markdown(doc)
    assert "| market | ∞ |" in table and "| market | 500 |" in table and "37.5" in table
