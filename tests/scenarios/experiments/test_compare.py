"""``compare`` (``scenarios.experiments.compare``) on short spatial runs: the table, the plot and
what they say (distance bids drive less than abstract ones)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenarios.experiments.compare import compare, fig_compare
from scenarios.experiments.output import strict_json

SHORT = (("stream.n_sets", 2), ("stream.learn_sets", 1), ("stream.test_sets", 1))


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    out = tmp_path_factory.mktemp("compare")
    doc = compare(
        "paper_spatial",
        ["abstract", "distance"],
        ["market", "expt"],
        [0, 1],
        out,
        workers=2,
        progress=False,
        overrides=SHORT,
    )
    return out, doc


@pytest.mark.slow
def test_compare_writes_table_and_plot(compared):
    out, doc = compared
    assert json.loads((out / "compare.json").read_text()) == strict_json(doc)  # NaN -> null
    assert set(doc["rows"]) == {
        "abstract/market",
        "abstract/expt",
        "distance/market",
        "distance/expt",
    }
    for row in doc["rows"].values():
        assert 0 < row["all"] <= 1 and row["distance_m"] > 0 and row["high_wait_s"] > 0
    assert np.isnan(doc["rows"]["abstract/market"]["space"])
    assert doc["rows"]["distance/expt"]["space"] <= 3498
    assert "| distance | market |" in (out / "compare.md").read_text()


@pytest.mark.slow
def test_distance_bids_drive_less_than_abstract_bids(compared):
    _, doc = compared
    rows = doc["rows"]
    assert rows["distance/market"]["distance_m"] < rows["abstract/market"]["distance_m"]


@pytest.mark.slow
def test_compare_figure_is_the_data(compared):
    _, doc = compared
    fig = fig_compare(doc)
    bars = [p for ax in fig.axes for p in ax.patches if p.get_gid()]
    assert len(bars) == 6 * 4
    for bar in bars:
        key, cost, alloc = bar.get_gid().split("|")
        value = doc["rows"][f"{cost}/{alloc}"][key]
        if not np.isnan(value):
            assert bar.get_height() == pytest.approx(value)
