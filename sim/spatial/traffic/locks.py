"""Directional locks on passages: one direction at a time, first come first served.

A passage may hold any number of robots going one way. A robot asks for a *chain* of
passages at once (each with its direction) and gets all or none: the deadlock of two robots
each holding one passage and waiting for the other's cannot arise. Requests are looked at in
the order they were made; one that is *ready* (the caller says so: the way beyond its exit is
free) claims an empty passage for its direction, so a younger request the other way cannot
overtake it. Robots may follow one another into a passage used their way, until a robot the
other way has waited ``turn_s``: then no one more enters that way, the passage empties and
turns.

Pure bookkeeping: positions, paths and time come from the caller
(``sim.spatial.traffic.rules.Traffic``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

Chain = tuple[tuple[int, int], ...]  # (passage key, direction +1 / -1), in path order


@dataclass(slots=True)
class Request:
    """A robot's standing request for a chain, and since when it has waited (s)."""

    chain: Chain
    since_s: float


class Locks:
    """The directional locks of a set of passages (keys are the caller's).

    Args:
        turn_s: opposing wait after which no robot more enters a passage the way it is used, s.

    Attributes:
        occupants: per passage key, the robots that hold it and their directions.
        requests: per robot, its waiting request.
        granted, forced, turns, turns_forced: counts since reset: chains granted; chains
            taken by a robot found inside without a lock; passages whose direction changed
            between grants; passages the opposing wait (``turn_s``) turned.
    """

    def __init__(self, turn_s: float) -> None:
        self.turn_s = turn_s
        self.occupants: dict[int, dict[int, int]] = {}
        self.requests: dict[int, Request] = {}
        self.last_direction: dict[int, int] = {}
        self.turning: set[int] = set()  # passages the opposing wait has turned, until it has
        self.granted = self.forced = self.turns = self.turns_forced = 0

    def request(self, j: int, chain: Chain, t: float) -> None:
        """Robot j asks for ``chain`` at ``t``; a robot that already waited for a chain
        sharing a passage keeps its place."""
        old = self.requests.get(j)
        if old is not None and old.chain == chain:
            return
        keys = {k for k, _ in chain}
        keep = old is not None and bool(keys & {k for k, _ in old.chain})
        self.requests[j] = Request(chain, old.since_s if keep else t)

    def cancel(self, j: int) -> None:
        """Robot j no longer waits."""
        self.requests.pop(j, None)

    def held_by(self, j: int) -> set[int]:
        """The passages robot j holds."""
        return {k for k, occ in self.occupants.items() if j in occ}

    def force(self, j: int, chain: Chain) -> None:
        """Robot j is in ``chain`` without its locks (given a path there, or pushed in): it
        holds them whatever the others do, so no robot more enters against it."""
        for key, d in chain:
            self.occupants.setdefault(key, {})[j] = d
        self.requests.pop(j, None)
        self.forced += 1

    def release(self, j: int, keys) -> None:
        """Robot j frees the passages ``keys``."""
        for key in keys:
            occ = self.occupants.get(key)
            if occ is not None:
                occ.pop(j, None)
                if not occ:
                    del self.occupants[key]

    def release_all(self, j: int) -> None:
        """Robot j frees every passage and stops waiting."""
        self.release(j, self.held_by(j))
        self.cancel(j)

    def drop_passage(self, key: int) -> None:
        """Passage ``key`` is gone (a robot at work left): nobody holds it."""
        self.occupants.pop(key, None)
        self.last_direction.pop(key, None)
        self.turning.discard(key)

    def grant(self, t: float, ready: Callable[[int], bool]) -> list[int]:
        """Grant what can be granted at ``t``, oldest request first: a chain whose every
        passage is empty (and not claimed the other way by an older ready request) or used
        its way only (and not turning), to a robot that is ``ready``. The robots granted."""
        order = sorted(self.requests.items(), key=lambda kv: (kv[1].since_s, kv[0]))
        claimed: dict[int, int] = {}
        out = []
        for j, req in order:
            is_ready = ready(j)
            ok = is_ready
            for key, d in req.chain:
                others = [e for r, e in self.occupants.get(key, {}).items() if r != j]
                if others:
                    if any(e != d for e in others) or self._turn_due(key, d, t, j):
                        ok = False
                elif claimed.get(key, d) != d:
                    ok = False
            if ok:
                for key, d in req.chain:
                    if self.last_direction.get(key, d) != d:
                        self.turns += 1
                        self.turning.discard(key)
                    self.last_direction[key] = d
                    self.occupants.setdefault(key, {})[j] = d
                del self.requests[j]
                self.granted += 1
                out.append(j)
            elif is_ready:
                for key, d in req.chain:
                    claimed.setdefault(key, d)
        return out

    def _turn_due(self, key: int, d: int, t: float, j: int) -> bool:
        """True if a robot other than j has waited ``turn_s`` for passage ``key`` against
        direction ``d`` (counted once per turn)."""
        for r, req in self.requests.items():
            if r != j and t - req.since_s >= self.turn_s and (key, -d) in req.chain:
                if key not in self.turning:
                    self.turning.add(key)
                    self.turns_forced += 1
                return True
        return False

    def counts(self) -> dict[str, int]:
        """The counts since reset, by name."""
        return {
            "grants": self.granted,
            "forced": self.forced,
            "turns": self.turns,
            "turns_forced": self.turns_forced,
        }
