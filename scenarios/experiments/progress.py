"""Progress bars for commands that run longer than a second (tqdm, on stderr).

Bars are shown only when stderr is a terminal (tqdm's ``disable=None``), so logs, pipes and CI
get no bar lines; ``--no-progress`` turns them off in a terminal too.
"""

from __future__ import annotations


def progress_bar(total: int, desc: str, unit: str = "run", enabled: bool = True):
    """A tqdm bar over ``total`` steps, or a silent one when disabled or not on a terminal."""
    from tqdm.auto import tqdm

    return tqdm(
        total=total,
        desc=desc,
        unit=unit,
        disable=None if enabled else True,
        dynamic_ncols=True,
        leave=False,
    )


def protocol_rounds(scenario) -> int:
    """Announcement rounds the paper protocol plays: learning sets, then test sets."""
    s = scenario.stream
    return (s.learn_sets + s.test_sets) * s.rounds_per_set
