"""Task streams: statistics within bounds, seeding, and file round trips."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import stats

from sim.tasks import StreamFileError, generate_stream, load_stream, save_stream


@pytest.fixture(scope="module")
def big_stream(paper):
    sc = dataclasses.replace(paper, stream=dataclasses.replace(paper.stream, n_sets=200))
    return generate_stream(sc, np.random.default_rng(12345))


def test_batch_sizes_are_uniform_3_to_7(big_stream):
    _, sizes = np.unique(big_stream.set_index * 1000 + big_stream.round_index, return_counts=True)
    assert sizes.min() == 3 and sizes.max() == 7
    counts = np.bincount(sizes, minlength=8)[3:]
    assert stats.chisquare(counts).pvalue > 1e-3
    assert abs(sizes.mean() - 5.0) < 4 * np.sqrt(2.0 / sizes.size)  # var of U{3..7} = 2


def test_priority_share_is_035(big_stream):
    n = len(big_stream)
    share = big_stream.high.mean()
    assert abs(share - 0.35) < 4 * np.sqrt(0.35 * 0.65 / n)


def test_types_are_uniform(big_stream, paper):
    counts = np.bincount(big_stream.types, minlength=paper.n_types)
    assert stats.chisquare(counts).pvalue > 1e-3


def test_about_90_tasks_a_set(paper):
    stream = generate_stream(paper, np.random.default_rng(0))
    per_set = np.bincount(stream.set_index)
    assert per_set.size == 45
    assert 70 <= per_set.mean() <= 110


def test_same_seed_same_stream_other_seed_other_stream(paper):
    a = generate_stream(paper, np.random.default_rng(7))
    b = generate_stream(paper, np.random.default_rng(7))
    c = generate_stream(paper, np.random.default_rng(8))
    for col in ("set_index", "round_index", "types", "high"):
        assert np.array_equal(getattr(a, col), getattr(b, col))
    assert not np.array_equal(a.types[:50], c.types[:50])


@pytest.mark.parametrize("suffix", [".json", ".csv"])
def test_round_trip(paper, tmp_path, suffix):
    stream = generate_stream(paper, np.random.default_rng(3))
    path = tmp_path / f"stream{suffix}"
    save_stream(stream, path)
    back = load_stream(path)
    for col in ("set_index", "round_index", "types", "high"):
        assert np.array_equal(getattr(stream, col), getattr(back, col))
    assert np.isnan(back.sites).all()
    assert (back.n_sets, back.rounds_per_set) == (stream.n_sets, stream.rounds_per_set)


def test_bad_stream_files_raise_one_line(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"n_sets": 2, "rounds_per_set": 3, "columns": {"id": [0]}}')
    with pytest.raises(StreamFileError, match=r"bad\.json: malformed"):
        load_stream(bad)
    with pytest.raises(StreamFileError, match="cannot read"):
        load_stream(tmp_path / "missing.csv")
