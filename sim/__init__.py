"""The world: scenario types, task streams, abstract and pymunk worlds, recording, rendering.

Knows nothing of auctions or learning.
"""
