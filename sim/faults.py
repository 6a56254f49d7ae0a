"""Robot breakdowns: seeded failure and repair times, for every world (issue 17).

A :class:`FaultModel` keeps, per robot, the time of its next failure, the time it is repaired
(``broken_until_s``; ``-inf`` while it works, ``inf`` once it is lost for good) and a lost-for-good
flag. Times to failure are exponential with the robot's mean (``FaultSpec.mttf_per_robot``): the
clock of a robot runs whether it works or idles, and a new time to failure is drawn when it is
repaired. Repair takes ``repair_s`` (``repair = "fixed"``) or an exponential time of that mean
(``"exponential"``); a failure is permanent with probability ``p_permanent``.

The model draws from its own generator, derived from the world's generator's seed sequence
(:func:`fault_seed_sequence`) without drawing from it or spawning from it: the stream, world and
allocator generators of a run are bit-identical with and without faults, and a scenario without
a ``[faults]`` table (or with an empty one) builds no model at all.

Draw order, fixed so that a run is reproducible: at :meth:`FaultModel.reset`, one exponential per
robot (robot order); at every failure (in time order, ties by robot index), the permanence draw
(only if ``0 < p_permanent``), then the repair draw (only for ``"exponential"`` repairs of a failure
that is not permanent); at every repair, one exponential for the robot's next time to failure.
Robots that never break (mean ``inf``) draw nothing.

The worlds ask :meth:`FaultModel.next_event_s` for the next failure or repair, advance their
clock to it and apply it with :meth:`FaultModel.step`, which returns the robots that broke and
those that were repaired.
"""

from __future__ import annotations

import json

import numpy as np

from sim.scenario import FaultSpec

FAULT_SPAWN_KEY = 0xFA17
"""The fault generator's seed sequence is the world's with this key appended to its spawn key:
a child of the world's sequence that ``SeedSequence.spawn`` never makes (it counts from 0)."""


def fault_seed_sequence(world_rng: np.random.Generator) -> np.random.SeedSequence:
    """The seed sequence of the fault generator of a world seeded with ``world_rng``.

    Built from the entropy and spawn key of the world generator's ``SeedSequence``: nothing is
    drawn from ``world_rng`` and nothing is spawned from its sequence, so its draws stay the same.
    A generator without a seed sequence (made from a bare bit generator state) gives
    ``SeedSequence(0)``'s child.
    """
    seq = getattr(world_rng.bit_generator, "seed_seq", None)
    if not isinstance(seq, np.random.SeedSequence):
        seq = np.random.SeedSequence(0)
    return np.random.SeedSequence(seq.entropy, spawn_key=(*seq.spawn_key, FAULT_SPAWN_KEY))


class FaultModel:
    """Failure and repair times of ``m`` robots.

    Args:
        spec: the scenario's ``[faults]`` table.
        names: the robots' names (``spec.mttf_by_robot`` refers to them).

    Attributes:
        next_fail_s: (m,) time of each robot's next failure (inf: never, or broken now).
        broken_until_s: (m,) end of the current repair; -inf while working, inf if lost for good.
        lost: (m,) robots lost for good.
        failures: (m,) failures so far; broken_s: (m,) time spent broken up to the last event.
    """

    def __init__(self, spec: FaultSpec, names) -> None:
        self.spec = spec
        self.mttf_s = spec.mttf_per_robot(list(names))
        self.reset(np.random.default_rng(np.random.SeedSequence(0)))

    @property
    def m(self) -> int:
        return int(self.mttf_s.size)

    def reset(self, rng: np.random.Generator) -> None:
        """Every robot works; draw each robot's first time to failure (from time 0)."""
        self.rng = rng
        m = self.m
        self.next_fail_s = np.full(m, np.inf)
        self.broken_until_s = np.full(m, -np.inf)
        self.broke_at_s = np.full(m, np.nan)
        self.lost = np.zeros(m, dtype=bool)
        self.failures = np.zeros(m, dtype=np.int64)
        self.broken_s = np.zeros(m)
        for j in range(m):
            self.next_fail_s[j] = self._time_to_failure(j, 0.0)

    def _time_to_failure(self, j: int, now_s: float) -> float:
        mean = float(self.mttf_s[j])
        if not np.isfinite(mean):
            return np.inf
        return now_s + float(self.rng.exponential(mean))

    # -- queries -------------------------------------------------------------------------------
    def broken(self, t_s: float) -> np.ndarray:
        """(m,) robots broken (or lost) at ``t_s``, as the last :meth:`step` left them."""
        return self.broken_until_s > t_s

    def broken_now(self) -> np.ndarray:
        """(m,) robots broken or lost after the last :meth:`step`."""
        return np.isfinite(self.broke_at_s)

    def next_event_s(self) -> float:
        """The next failure or repair (inf if none is due)."""
        repairs = self.broken_until_s[np.isfinite(self.broken_until_s)]
        return float(min(self.next_fail_s.min(initial=np.inf), repairs.min(initial=np.inf)))

    def availability(self, t_s: float) -> np.ndarray:
        """(m,) share of [0, t_s] each robot was not broken (1 where t_s is 0)."""
        down = self.broken_s.copy()
        now = self.broken_now()
        down[now] += np.maximum(t_s - self.broke_at_s[now], 0.0)
        return 1.0 - down / t_s if t_s > 0 else np.ones(self.m)

    # -- events --------------------------------------------------------------------------------
    def step(self, t_s: float) -> tuple[list[int], list[int]]:
        """Apply every failure and repair due by ``t_s``, in time order (ties: repairs first,
        then by robot index); return (robots that broke, robots that were repaired)."""
        broke, fixed = [], []
        while True:
            t_next = self.next_event_s()
            if t_next > t_s or t_next == np.inf:  # inf: nothing is ever due, even by t_s = inf
                return broke, fixed
            due_fix = np.flatnonzero(self.broken_until_s == t_next).tolist()
            for j in due_fix:
                self.broken_s[j] += t_next - self.broke_at_s[j]
                self.broke_at_s[j] = np.nan
                self.broken_until_s[j] = -np.inf
                self.next_fail_s[j] = self._time_to_failure(j, t_next)
                fixed.append(j)  # a robot may break and be repaired in one step: in both
            for j in np.flatnonzero(self.next_fail_s == t_next).tolist():
                self._fail(j, t_next)
                broke.append(j)

    def _fail(self, j: int, t_s: float) -> None:
        spec = self.spec
        self.failures[j] += 1
        self.next_fail_s[j] = np.inf
        self.broke_at_s[j] = t_s
        permanent = spec.p_permanent > 0 and float(self.rng.random()) < spec.p_permanent
        if permanent:
            self.lost[j] = True
            self.broken_until_s[j] = np.inf
            return
        if spec.repair == "exponential":
            repair = float(self.rng.exponential(spec.repair_s)) if spec.repair_s > 0 else 0.0
        else:
            repair = spec.repair_s
        self.broken_until_s[j] = t_s + repair

    # -- checkpoints ---------------------------------------------------------------------------
    def state_arrays(self) -> dict[str, np.ndarray]:
        """The model as plain arrays (the generator's state as JSON text in a 0-d str array)."""
        return {
            "next_fail_s": self.next_fail_s.copy(),
            "broken_until_s": self.broken_until_s.copy(),
            "broke_at_s": self.broke_at_s.copy(),
            "lost": self.lost.copy(),
            "failures": self.failures.copy(),
            "broken_s": self.broken_s.copy(),
            "rng_state": np.array(json.dumps(self.rng.bit_generator.state)),
        }

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of :meth:`state_arrays`; a state for another number of robots is refused
        before anything changes."""
        n = np.asarray(arrays["next_fail_s"]).size
        if n != self.m:
            raise ValueError(f"fault state for {n} robots, not {self.m}")
        self.next_fail_s = np.asarray(arrays["next_fail_s"], dtype=float).copy()
        self.broken_until_s = np.asarray(arrays["broken_until_s"], dtype=float).copy()
        self.broke_at_s = np.asarray(arrays["broke_at_s"], dtype=float).copy()
        self.lost = np.asarray(arrays["lost"], dtype=bool).copy()
        self.failures = np.asarray(arrays["failures"], dtype=np.int64).copy()
        self.broken_s = np.asarray(arrays["broken_s"], dtype=float).copy()
        state = json.loads(str(arrays["rng_state"]))
        rng = np.random.Generator(getattr(np.random, state["bit_generator"])())
        rng.bit_generator.state = state
        self.rng = rng


def build_faults(scenario) -> FaultModel | None:
    """The scenario's fault model, or None if no robot can break (nothing changes then)."""
    if not scenario.has_faults:
        return None
    return FaultModel(scenario.faults, [r.name for r in scenario.robots])
