"""``soak`` (``scenarios.experiments.soak``): a short soak of the large scenario accounts for every
task, without overlap or memory growth."""

from __future__ import annotations

import pytest

from scenarios.experiments.soak import soak


@pytest.mark.slow
def test_soak_short():
    result = soak("large", tasks=400, progress=False)
    assert result["tasks_announced"] >= 400
    assert result["tasks_allocated"] <= result["tasks_announced"]
    assert result["tasks_failed"] == 0
    assert result["max_overlap_m"] <= 0.01
    assert result["rss_growth_mib"] < 50
