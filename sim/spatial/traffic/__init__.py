"""Traffic rules for single-lane passages (``[spatial.traffic] rules = "on"``, avoidance on).

Fleets keep robots from meeting head-on where they cannot pass each other with mutex zones and
holding points (Open-RMF), zone control (AGVs) or block signalling (railways). Here:

- ``geometry``: convex polygons, lines through them, rectangles (pure functions; the ones
  asked per event are compiled in ``sim.spatial.plane``);
- ``passages``: the passages found from the arena at load (gaps narrower than two lanes) and
  the temporary ones beside a robot at work;
- ``annotate``: a path's crossings of passages, grouped into chains, and the holding points
  before a mouth;
- ``locks``: directional locks, first come first served, a chain at once, the direction
  turning after a bounded opposing wait;
- ``rules``: :class:`Traffic`, which runs them once per control period for the fleet.

``sim.spatial.jobs.Jobs`` owns one when the rules are on; the jam rules
(``sim.spatial.jams``) stay the fallback.
"""

from sim.spatial.traffic.passages import Passage, find_passages
from sim.spatial.traffic.rules import Traffic

__all__ = ["Passage", "Traffic", "find_passages"]
