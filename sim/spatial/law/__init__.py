"""The laws of motion the control period applies: pure functions of numbers and arrays.

``drive``: the drive law's formulas (steering, braking, proximity caps, wheel limits);
``orca``: reciprocal velocity-level collision avoidance for differential-drive robots.
"""
