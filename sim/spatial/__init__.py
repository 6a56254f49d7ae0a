"""The pymunk world: differential-drive robots driving to task sites in a physics arena.

One room per concern, the pure laws at the bottom:

- ``law/``: the drive law's formulas (``law.drive``) and ORCA collision avoidance
  (``law.orca``), pure functions of numbers and arrays;
- ``navigation/``: planning round obstacles and following paths; knows only the arena;
- ``controller``, ``motors``, ``contacts``: the drive controller over arrays, the robots'
  bodies and motor joints, stepping the space and counting contacts;
- ``fleet``: the fleet's per-robot state, the schedule of checks and the clock;
- ``jobs``, ``sites``, ``jams``: task bookkeeping, site slots and queues, jam rules;
- ``stalls``: where driving robots stand still and why;
- ``control/``: the control period (poses in, motor commands out);
- ``world``: :class:`PymunkWorld`, which builds the space and owns the state.
"""

from sim.spatial.world import PymunkWorld

__all__ = ["PymunkWorld"]
