"""``mrta bench``: every benchmark in one room.

- :mod:`scenarios.bench.loop`: the simulation loop against bare ``space.step`` (10, 100 and
  1000 robots; planned-distance bids and the distance field's cost);
- :mod:`scenarios.bench.gif`: our GIF writer against FuncAnimation + PillowWriter;
- :mod:`scenarios.bench.alloc`: allocation time and memory per round against team size, cost
  models, and scipy's assignment against LAPJV;
- :mod:`scenarios.bench.run`: the command that runs the parts and reports ratios measured in
  one process.
"""

from scenarios.bench.run import run_bench

__all__ = ["run_bench"]
