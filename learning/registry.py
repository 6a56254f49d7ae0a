"""Which allocator a name means: built-ins, installed plug-ins, or ``module:Class``.

Allocators are found, in this order:

1. ``module:Class`` (``mypkg.alloc:Greedy``): imported from the module, which must be
   importable: installed, on ``PYTHONPATH``, or a file in the current folder (``my_alloc.py``
   for ``my_alloc:Budget``, as ``python -m`` would find it);
2. a name registered under the entry-point group ``expt_mrta.allocators`` by any installed
   package (the built-ins are registered there too, in this package's ``pyproject.toml``);
3. the built-in table :data:`BUILTIN_ALLOCATORS` (so a source checkout that is not
   installed still knows ``market``, ``ql``, ``expt``, ``greedy`` and ``cbba``).

A class qualifies if it has ``allocate`` and the other methods of
:class:`allocation.base.Allocator`; anything else is refused with one line naming what is
missing.
"""

from __future__ import annotations

import difflib
import importlib
import os
import sys
from importlib.metadata import entry_points

from allocation.auction import MarketAllocator
from allocation.base import Allocator
from allocation.cbba import CBBAAllocator
from allocation.greedy import GreedyAllocator
from learning.exptmrta import ExpTAllocator
from learning.qlmrta import QLAllocator

PAPER_ALLOCATORS: dict[str, type] = {
    "market": MarketAllocator,
    "ql": QLAllocator,
    "expt": ExpTAllocator,
}
BUILTIN_ALLOCATORS: dict[str, type] = {
    **PAPER_ALLOCATORS,
    "greedy": GreedyAllocator,
    "cbba": CBBAAllocator,
}

GROUP = "expt_mrta.allocators"
REQUIRED = (
    "reset",
    "begin_set",
    "allocate",
    "end_set",
    "willing",
    "allowed",
    "learning_space",
    "experience_snapshot",
)


class AllocatorError(ValueError):
    """An allocator name that cannot be resolved, or a class that is not an allocator."""


def installed() -> dict[str, str]:
    """Entry-point name -> ``module:Class`` of every allocator installed packages register."""
    return {ep.name: ep.value for ep in entry_points(group=GROUP)}


def available() -> list[str]:
    """Every allocator name that resolves without a ``module:`` prefix, sorted."""
    return sorted(set(BUILTIN_ALLOCATORS) | set(installed()))


def allocator_class(name: str) -> type[Allocator]:
    """The allocator class ``name`` stands for (see the module docstring for the order)."""
    if ":" in name:
        cls = _import(name)
    elif name in (eps := installed()):
        cls = _import(eps[name])
    elif name in BUILTIN_ALLOCATORS:
        cls = BUILTIN_ALLOCATORS[name]
    else:
        close = difflib.get_close_matches(name, available(), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise AllocatorError(
            f"unknown allocator {name!r}{hint}; one of {', '.join(available())}, or module:Class"
        )
    missing = [m for m in REQUIRED if not callable(getattr(cls, m, None))]
    if missing or not isinstance(cls, type):
        what = ", ".join(missing) if missing else "not a class"
        raise AllocatorError(f"allocator {name!r}: {what} (see docs/allocators.md)")
    return cls


def _import(target: str) -> type:
    module_name, _, attr = target.partition(":")
    if not module_name or not attr:
        raise AllocatorError(f"allocator {target!r}: write it as module:Class")
    try:
        module = _import_module(module_name)
    except Exception as exc:  # the plug-in's own code runs here: any error is its problem
        what = f"{type(exc).__name__}: {exc}" if not isinstance(exc, ImportError) else str(exc)
        raise AllocatorError(
            f"allocator {target!r}: cannot import {module_name!r} ({what})"
        ) from exc
    try:
        obj = module
        for part in attr.split("."):
            obj = getattr(obj, part)
    except AttributeError:
        raise AllocatorError(f"allocator {target!r}: {module_name} has no {attr!r}") from None
    return obj


def _import_module(name: str):
    """``importlib.import_module(name)``; a module not found is looked for again in the current
    folder, which stays first on ``sys.path`` from then on (worker processes inherit it)."""
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        here = os.getcwd()
        top = name.split(".")[0]
        if exc.name != top or here in sys.path or not _in_folder(here, top):
            raise
        sys.path.insert(0, here)
        return importlib.import_module(name)


def _in_folder(folder: str, top: str) -> bool:
    """True if ``folder`` holds module or package ``top``."""
    return os.path.isfile(os.path.join(folder, f"{top}.py")) or os.path.isfile(
        os.path.join(folder, top, "__init__.py")
    )
