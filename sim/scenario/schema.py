"""Settings with their meaning attached: type, default, unit, range, allowed words, one line of doc.

Every field of a scenario's spec dataclasses is declared with :func:`setting` (a value) or
:func:`table` (a nested spec, a sub-table of the scenario file). The declaration is the single
truth for that key: :func:`check_settings`, which every spec calls when it is built, checks the
value against it, whichever door it came through (a scenario file, a scenario built in Python, a
run's overrides, a sweep's grid, an environment's keyword arguments); the scenario-file reference
(``docs/scenario-files.md``) is generated from it; and the loader's unknown-key check reads the
same field list.

A problem raises :class:`ScenarioError`, whose message is one line: ``key.path: problem`` (the
loader puts the file in front: ``file: key.path: problem``).
"""

from __future__ import annotations

import difflib
import math
import numbers
from dataclasses import MISSING, Field, dataclass, field, fields
from typing import Any


class ScenarioError(ValueError):
    """A scenario (or a setting) that cannot be used; ``str(err)`` is one line.

    Raised by a spec as ``ScenarioError.at("stream.batch_min", "must be at least 1")`` it knows
    the key path and the problem; the loader puts the file in front with :meth:`located`.
    """

    def __init__(self, message: str, *, path: str | None = None, problem: str = "") -> None:
        super().__init__(message)
        self.path = path  # None: a whole line already (a file that cannot be read, say)
        self.problem = problem or message

    @classmethod
    def at(cls, path: str, problem: str) -> ScenarioError:
        """The error of the setting ``path`` (``section.key``)."""
        return cls(f"{path or '<top level>'}: {problem}", path=path, problem=problem)

    def located(self, source: str) -> ScenarioError:
        """The same error with ``source`` (a file, ``override``, ...) in front."""
        if not source or self.path is None:
            return self
        return ScenarioError(f"{source}: {self}", path=self.path, problem=self.problem)


def fail(path: str, problem: str):
    """Raise :class:`ScenarioError` for the setting ``path``."""
    raise ScenarioError.at(path, problem)


def did_you_mean(word: str, options) -> str:
    """' (did you mean 'x'?)' for the closest option, ignoring case; '' if none is close."""
    lower = {str(o).lower(): o for o in options}
    close = difflib.get_close_matches(str(word).lower(), list(lower), n=1, cutoff=0.6)
    return f" (did you mean {lower[close[0]]!r}?)" if close else ""


def kind_of(val: Any) -> str:
    """How a value reads in a message: ``string 'x'``, ``number 3``, ``a list`` ..."""
    if isinstance(val, bool):
        return f"boolean {str(val).lower()}"
    if isinstance(val, str):
        return f"string {val!r}"
    if isinstance(val, numbers.Real):
        return f"number {val}"
    if isinstance(val, list | tuple):
        return "a list"
    if isinstance(val, dict):
        return "a table"
    return type(val).__name__


@dataclass(frozen=True, slots=True)
class Setting:
    """What a setting may hold and what it means.

    Attributes:
        doc: one line: what the setting changes.
        unit: its unit ("m", "s", "m/s", ...; "" for counts, shares and words).
        lo, hi: the closed (or, with ``lo_open``/``hi_open``, open) range of a number; None:
            unbounded on that side.
        choices: the allowed words of a string setting.
        inf_ok: ``inf`` (or the string ``"inf"``) is allowed besides the range (never, for a
            mean time to failure).
        note: said after a range error (why the range is what it is).
    """

    doc: str
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] = ()
    inf_ok: bool = False
    note: str = ""

    def range_text(self) -> str:
        """The range as the docs and the messages write it: ``[0, 1]``, ``> 0``, ``(0, 60]``."""
        if self.lo is not None and self.hi is not None:
            left, right = "(" if self.lo_open else "[", ")" if self.hi_open else "]"
            return f"{left}{_num(self.lo)}, {_num(self.hi)}{right}"
        if self.lo is not None:
            return f"{'>' if self.lo_open else '>='} {_num(self.lo)}"
        if self.hi is not None:
            return f"{'<' if self.hi_open else '<='} {_num(self.hi)}"
        return ""


def _num(x: float) -> str:
    """A bound as written in messages and docs: 10000 as 10,000, 1e9 as 1e9, 0.05 as 0.05."""
    if float(x).is_integer() and abs(x) >= 1e6 and f"{abs(x):.0e}".startswith("1e"):
        return f"{x:.0e}".replace("e+0", "e").replace("e+", "e")
    if float(x).is_integer() and abs(x) >= 10_000:
        return f"{int(x):,}"
    return f"{x:g}"


def setting(default: Any, doc: str, **meta: Any) -> Any:
    """A dataclass field holding one setting: its default and its :class:`Setting`."""
    return field(default=default, metadata={"setting": Setting(doc, **meta)})


def required(doc: str, **meta: Any) -> Any:
    """A dataclass field holding one setting that has no default."""
    return field(metadata={"setting": Setting(doc, **meta)})


def table(factory: type, doc: str) -> Any:
    """A dataclass field holding a nested spec: a sub-table of the scenario file."""
    return field(default_factory=factory, metadata={"table": doc})


def settings_of(cls: type) -> list[tuple[Field, Setting]]:
    """The (field, :class:`Setting`) pairs of a spec class, in declaration order."""
    return [(f, f.metadata["setting"]) for f in fields(cls) if "setting" in f.metadata]


def tables_of(cls: type) -> list[Field]:
    """The nested-spec fields of a spec class (sub-tables), in declaration order."""
    return [f for f in fields(cls) if "table" in f.metadata]


def value_type(f: Field) -> type:
    """The Python type a setting holds: bool, int, float, str (from its default or annotation)."""
    if f.default is not MISSING and f.default is not None:
        return type(f.default)
    text = str(f.type)
    for name, kind in (("bool", bool), ("int", int), ("float", float), ("str", str)):
        if text.startswith(name):
            return kind
    return object


def check_settings(spec: Any, section: str) -> None:
    """Check every setting of ``spec`` against its declaration; normalise numbers in place.

    An int given for a float setting becomes a float (as TOML's ``10`` for ``10.0``); a numpy
    scalar becomes the Python number. Raises :class:`ScenarioError` naming ``section.key``.
    """
    for f, meta in settings_of(type(spec)):
        path = f"{section}.{f.name}" if section else f.name
        kind = value_type(f)
        val = getattr(spec, f.name)
        if kind is object:
            continue
        new = check_value(val, kind, meta, path)
        if new is not val:
            object.__setattr__(spec, f.name, new)


def check_value(val: Any, kind: type, meta: Setting, path: str) -> Any:
    """``val`` as a setting of type ``kind`` under ``meta``, normalised; or ScenarioError."""
    if kind is bool:
        if not isinstance(val, bool | _np_bool()):
            fail(path, f"must be true or false, got {kind_of(val)}")
        return bool(val)
    if kind is str:
        if not isinstance(val, str):
            fail(path, f"must be a string, got {kind_of(val)}")
        if meta.choices and val not in meta.choices:
            hint = did_you_mean(val, meta.choices)
            words = " or ".join(f'"{c}"' for c in meta.choices)
            fail(path, f"must be {words}; got {val!r}{hint}")
        return val
    if meta.inf_ok and (val == "inf" or (isinstance(val, float) and val == math.inf)):
        return math.inf
    if isinstance(val, bool) or not isinstance(val, numbers.Real):
        fail(path, f"must be a number, got {kind_of(val)}")
    if kind is int:
        if not isinstance(val, numbers.Integral):
            fail(path, f"must be an integer, got {val!r}")
        val = int(val)
    else:
        val = float(val)
        if not math.isfinite(val):
            fail(path, f"must be finite, got {val}")
    lo_bad = meta.lo is not None and (val < meta.lo or (meta.lo_open and val == meta.lo))
    hi_bad = meta.hi is not None and (val > meta.hi or (meta.hi_open and val == meta.hi))
    if lo_bad or hi_bad:
        unit = f" {meta.unit}" if meta.unit and meta.unit not in ("1", "") else ""
        note = f" ({meta.note})" if meta.note else ""
        rng = meta.range_text()
        words = f"must be in {rng}" if rng[0] in "[(" else f"must be {rng}"
        fail(path, f"{words}{unit}{note}, got {val}")
    return val


def _np_bool():
    import numpy as np

    return np.bool_


def check_table(table: dict, path: str, allowed: type | tuple[str, ...]) -> None:
    """Fail on the first key of a scenario-file table that is not ``allowed``: a spec class
    (its fields) or the key names."""
    if isinstance(allowed, type):
        allowed = tuple(f.name for f in fields(allowed))
    for key in table:
        if key not in allowed:
            where = f"{path}.{key}" if path else key
            fail(where, f"unknown key{did_you_mean(key, sorted(allowed))}")


__all__ = [
    "ScenarioError",
    "Setting",
    "check_settings",
    "check_table",
    "check_value",
    "did_you_mean",
    "fail",
    "kind_of",
    "required",
    "setting",
    "settings_of",
    "table",
    "tables_of",
    "value_type",
]
