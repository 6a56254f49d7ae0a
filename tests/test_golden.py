"""Golden runs: fixed seeds, abstract and pymunk worlds, both control paths, bit for bit.

A restructure must leave every number and every trajectory exactly as it was. When a change is
meant to alter results, regenerate with ``python tests/golden/cases.py`` and say why in the
commit message.
"""

from __future__ import annotations

import json

import pytest

from tests.golden.cases import CASES, GOLDEN, run_case

EXPECTED = json.loads(GOLDEN.read_text())


def test_every_case_is_recorded():
    assert sorted(EXPECTED) == sorted(name for name, *_ in CASES)


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_golden_run_is_bit_identical(case):
    name, *args = case
    got = run_case(*args)
    want = EXPECTED[name]
    assert got.get("trajectory") == want.get("trajectory"), f"{name}: trajectory changed"
    assert canonical(got["summary"]) == canonical(want["summary"]), f"{name}: metrics changed"


def canonical(doc) -> str:
    """JSON text with sorted keys: floats by repr, NaN as a token (NaN != NaN as objects)."""
    return json.dumps(doc, sort_keys=True, allow_nan=True)
