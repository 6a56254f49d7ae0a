"""Where a robot can go and how it gets there: planning round obstacles and following paths.

``planning`` plans exact any-angle shortest paths round the arena's inflated obstacles (its
``GridPlanner`` is what the rest of the world asks); ``distfield`` gives a whole fleet's
planned-path distances to the task sites from one grid per site, refined near obstacles by
``anchors``, with ``raster`` telling which cells see a point; ``buckets`` finds the few
obstacles or edges a small query can touch; ``paths`` follows the planned paths and says how
close a robot may come to the obstacles on either side.

The package knows the arena (``sim.scenario``) and nothing else of the world: no robots' state,
no pymunk. Import the modules themselves (``from sim.spatial.navigation.planning import
GridPlanner``); this ``__init__`` loads nothing, so asking for one never loads scipy's graph
routines for another.
"""
