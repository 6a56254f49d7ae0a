"""Golden runs: fixed seeds, abstract and pymunk worlds, both control paths, bit for bit.

A restructure must leave every number and every trajectory exactly as it was. When a change is
meant to alter results, regenerate with ``python tests/golden/cases.py`` and say why in the
commit message.
"""

from __future__ import annotations

import json
import platform

import pytest

from tests.golden.cases import CASES, GOLDEN, MACHINE, compute_portable

EXPECTED = json.loads(GOLDEN.read_text())
pytestmark = pytest.mark.skipif(
    platform.machine() != MACHINE,
    reason=f"golden.json holds the bits of {MACHINE}; other architectures round differently",
)


@pytest.fixture(scope="module")
def computed() -> dict:
    """Every case, run once in a child Python with numpy's baseline kernels (the same bits on
    every x86-64 machine: ``tests/golden/cases.py``)."""
    return compute_portable()


def test_every_case_is_recorded():
    assert sorted(EXPECTED) == sorted(name for name, *_ in CASES)


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_golden_run_is_bit_identical(case, computed):
    name = case[0]
    got = computed[name]
    want = EXPECTED[name]
    assert got.get("trajectory") == want.get("trajectory"), f"{name}: trajectory changed"
    assert canonical(got["summary"]) == canonical(want["summary"]), f"{name}: metrics changed"


@pytest.mark.slow
def test_golden_runs_do_not_depend_on_the_blas_kernel():
    """OpenBLAS picks its kernels by CPU model, and its AVX-512 ones (SkylakeX, picked on the
    Intel machines here) round a dot product differently from its AVX2 ones (Haswell; Zen, on
    the AMD machines): until the planner's dot products were written out, paper_spatial's runs
    parted between the two after a few hundred seconds. The same case with the AVX-512
    kernels must give the recorded bits (written with the machine's own)."""
    from numpy._core import _multiarray_umath as umath

    if not umath.__cpu_features__.get("AVX512_SKX", False):
        pytest.skip("OpenBLAS's SkylakeX kernels need AVX-512")
    name = "spatial_expt_distance_scalar"
    got = compute_portable([name], env={"OPENBLAS_CORETYPE": "SkylakeX"})[name]
    assert got["trajectory"] == EXPECTED[name]["trajectory"]
    assert canonical(got["summary"]) == canonical(EXPECTED[name]["summary"])


def canonical(doc) -> str:
    """JSON text with sorted keys: floats by repr, NaN as a token (NaN != NaN as objects)."""
    return json.dumps(doc, sort_keys=True, allow_nan=True)
