"""The compiled control period's kernel (numba, ``@njit(cache=True)``, no fastmath).

One algorithm per module, each the numpy law's rules for one robot at a time:

- ``settings``: the law's numbers as plain arguments (no globals, no recompilation per scenario);
- ``obstacles``: the nearest obstacle point; ``neighbours``: a uniform grid and k nearest;
- ``halfplanes``: ORCA's lines; ``linprog``: RVO2's linear programs 1, 2 and 3;
- ``avoid``: ORCA's commands; ``drive``: path aim, steering, speed caps, wheel limits;
- ``steering`` and ``commands``: the two halves of a period, over every robot; ``period``:
  both in one call; ``quiet``: whether the Python checks due (stuck, arrival, site queues)
  have anything to do but set their next times;
- ``freewidth``: the free widths of a path segment (``PathFollower._free``, compiled);
- ``views``: their arguments built from the world's objects; ``loading``: the cache, the
  one-line notice of a first compilation, the warm-up.

``sim.spatial.control.compiled.CompiledControl`` calls it and handles the events in Python.
"""
