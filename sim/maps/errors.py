"""The one error a map raises: a single line naming the file, the key and the problem."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class MapError(ValueError):
    """A map that cannot be used: ``'<file>: <key>: <problem>'``, on one line.

    Args:
        source: the map file as the caller named it (usually the YAML file).
        key: the YAML key (``image``, ``origin``, ...) or another short location (``yaml``).
        problem: what is wrong, in a few words; newlines are folded into spaces.
    """

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source, self.key = str(source), key
        self.problem = " ".join(str(problem).split())
        super().__init__(f"{self.source}: {key}: {self.problem}")


def did_you_mean(word: str, options: Iterable[str]) -> str:
    """``" (did you mean 'x'?)"`` for the option closest to ``word`` (ignoring case), else ''."""
    lower = {str(o).lower(): str(o) for o in options}
    close = difflib.get_close_matches(word.lower(), list(lower), n=1, cutoff=0.6)
    return f" (did you mean {lower[close[0]]!r}?)" if close else ""
