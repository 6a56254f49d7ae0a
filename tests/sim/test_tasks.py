"""Task streams: statistics within bounds, seeding, and file round trips."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy import stats

from sim.scenario import SpatialSpec
from sim.tasks import StreamFileError, TaskStream, generate_stream, load_stream, save_stream


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


HAND = TaskStream(
    set_index=np.array([0, 0, 1]),
    round_index=np.array([0, 1, 0]),
    types=np.array([2, 0, 1]),
    high=np.array([True, False, True]),
    sites=np.array([[1.5, 2.0], [np.nan, np.nan], [3.0, 4.25]]),
    n_sets=2,
    rounds_per_set=2,
)


def assert_same_stream(a: TaskStream, b: TaskStream) -> None:
    for col in ("set_index", "round_index", "types", "high", "sites"):
        np.testing.assert_array_equal(getattr(a, col), getattr(b, col))
        assert getattr(a, col).dtype.kind == getattr(b, col).dtype.kind, col
    assert (a.n_sets, a.rounds_per_set) == (b.n_sets, b.rounds_per_set)


def test_csv_file_is_exactly_the_documented_columns(tmp_path):
    path = tmp_path / "s.csv"
    save_stream(HAND, path)
    assert path.read_bytes() == (
        b"# n_sets=2 rounds_per_set=2\n"
        b"id,set,round,type,high,x,y\r\n"
        b"0,0,0,2,1,1.5,2.0\r\n"
        b"1,0,1,0,0,,\r\n"
        b"2,1,0,1,1,3.0,4.25\r\n"
    )
    assert [p.name for p in tmp_path.iterdir()] == ["s.csv"]  # the temporary file is gone
    assert_same_stream(load_stream(path), HAND)


def test_json_file_is_exactly_the_documented_columns(tmp_path):
    path = tmp_path / "s.json"
    save_stream(HAND, path)
    assert json.loads(path.read_text()) == {
        "n_sets": 2,
        "rounds_per_set": 2,
        "columns": {
            "id": [0, 1, 2],
            "set": [0, 0, 1],
            "round": [0, 1, 0],
            "type": [2, 0, 1],
            "high": [1, 0, 1],
            "x": [1.5, None, 3.0],
            "y": [2.0, None, 4.25],
        },
    }
    assert [p.name for p in tmp_path.iterdir()] == ["s.json"]
    assert_same_stream(load_stream(path), HAND)


def test_rows_are_put_in_set_and_round_order_on_load(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text(
        "# n_sets=2 rounds_per_set=2\nid,set,round,type,high,x,y\n"
        "0,1,0,1,1,3.0,4.25\n1,0,1,0,0,,\n2,0,0,2,1,1.5,2.0\n"
    )
    assert_same_stream(load_stream(path), HAND)


@pytest.mark.parametrize(
    ("column", "value", "message"),
    [
        ("set", 2, "column 'set' outside 0..1"),
        ("set", -1, "column 'set' outside 0..1"),
        ("round", 2, "column 'round' outside 0..1"),
        ("round", -1, "column 'round' outside 0..1"),
    ],
)
def test_set_and_round_out_of_range_are_refused(tmp_path, column, value, message):
    path = tmp_path / "s.json"
    save_stream(HAND, path)
    doc = json.loads(path.read_text())
    doc["columns"][column][1] = value
    path.write_text(json.dumps(doc))
    with pytest.raises(StreamFileError) as info:
        load_stream(path)
    assert str(info.value) == f"{path}: {message}"


def test_spatial_tasks_sit_on_their_types_sites(paper):
    two = ((1.0, 1.0), (2.0, 2.0))
    sites = tuple(tuple((x + 10 * i, y) for x, y in two) for i in range(paper.n_types))
    spatial = SpatialSpec(100.0, 100.0, (), sites)
    robots = tuple(
        dataclasses.replace(r, start_xy=(50.0, 5.0 * j)) for j, r in enumerate(paper.robots)
    )
    scenario = dataclasses.replace(paper, robots=robots, spatial=spatial)
    stream = generate_stream(scenario, np.random.default_rng(3))
    for i in range(paper.n_types):
        xs = stream.sites[stream.types == i]
        # every task of type i at one of its two sites, and both sites used
        assert {tuple(p) for p in xs.tolist()} == {(1.0 + 10 * i, 1.0), (2.0 + 10 * i, 2.0)}


def test_malformed_stream_file_names_the_error(tmp_path):
    path = tmp_path / "s.json"
    path.write_text('{"n_sets": 2, "rounds_per_set": 2, "columns": {"id": [0]}}')
    with pytest.raises(StreamFileError) as info:
        load_stream(path)
    assert str(info.value) == f"{path}: malformed stream file (KeyError: 'set')"


def test_abstract_tasks_have_no_site(paper):
    stream = generate_stream(paper, np.random.default_rng(0))
    assert stream.sites.dtype == float and stream.sites.shape == (len(stream), 2)
    assert np.isnan(stream.sites).all()


def test_batches_give_each_round_of_a_set_in_order_with_its_rows():
    """A hand-made stream of 2 sets x 3 rounds (set 1, round 1 empty): each batch holds the
    stream's row ids of its round, and their types, priorities and sites."""
    stream = TaskStream(
        set_index=np.array([0, 0, 0, 0, 1, 1, 1]),
        round_index=np.array([0, 0, 1, 2, 0, 2, 2]),
        types=np.array([2, 0, 1, 1, 0, 2, 1]),
        high=np.array([True, False, False, True, True, False, False]),
        sites=np.arange(14, dtype=float).reshape(7, 2),
        n_sets=2,
        rounds_per_set=3,
    )
    assert len(stream) == 7
    got = list(stream.batches(1))
    assert [(b.set_index, b.round_index, len(b)) for b in got] == [(1, 0, 1), (1, 1, 0), (1, 2, 2)]
    last = got[2]
    assert last.ids.tolist() == [5, 6] and last.types.tolist() == [2, 1]
    assert last.high.tolist() == [False, False] and last.sites.tolist() == [[10, 11], [12, 13]]
    first = list(stream.batches(0))
    assert [b.ids.tolist() for b in first] == [[0, 1], [2], [3]]
    assert first[0].types.tolist() == [2, 0] and first[0].high.tolist() == [True, False]
    assert first[0].sites.tolist() == [[0, 1], [2, 3]]
    assert [len(b) for b in stream.batches(2)] == [0, 0, 0]  # no such set: empty rounds
