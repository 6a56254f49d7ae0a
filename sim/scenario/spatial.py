"""The ``[spatial]`` table: arena, robot body, rates, and the rules of the pymunk world.

Every number a researcher may tune lives here, with its unit and range, in one sub-table per
concern: ``[spatial.drive]`` (the robot body), ``[spatial.law]`` (steering and the proximity
law), ``[spatial.orca]`` (collision avoidance), ``[spatial.follow]`` (path following),
``[spatial.queue]`` (site slots and queues), ``[spatial.make_way]`` (idle robots stepping
aside), ``[spatial.recovery]`` (stuck robots), ``[spatial.jams]`` (jams between driving robots),
``[spatial.stalls]`` (the stall meter) and ``[spatial.contacts]`` (the contact solver). Every key
is optional; the defaults are the bundled scenarios' values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from sim.scenario.maps import check_map_arena, map_arena, shifted_points
from sim.scenario.schema import check_settings, fail, kind_of, required, setting, table

AVOIDANCE = ("orca", "none")
LOOK_AHEAD = ("off", "on")
TRAFFIC_RULES = ("off", "on")
MAX_GRID_CELLS = 4_000_000
MAX_SITES = 10_000
MAX_ARENA_M = 10_000.0


def _positive(default: float, doc: str, hi: float, unit: str = "", **meta: Any) -> Any:
    return setting(default, doc, unit=unit, lo=0.0, lo_open=True, hi=hi, **meta)


def _between(default: float, doc: str, lo: float, hi: float, unit: str = "") -> Any:
    return setting(default, doc, unit=unit, lo=lo, hi=hi)


def _share(default: float, doc: str, hi: float = 1.0, unit: str = "") -> Any:
    return setting(default, doc, unit=unit, lo=0.0, hi=hi)


class _Section:
    """A sub-table of the scenario file: checks its settings when built."""

    __slots__ = ()
    SECTION: ClassVar[str] = ""

    def __post_init__(self) -> None:
        check_settings(self, self.SECTION)


@dataclass(frozen=True, slots=True)
class DriveSpec(_Section):
    """The differential-drive robot body (``[spatial.drive]``)."""

    SECTION: ClassVar[str] = "spatial.drive"
    radius_m: float = _between(0.25, "robot radius (a disc)", 0.01, 5.0, "m")
    mass_kg: float = _between(20.0, "robot mass", 0.1, 10_000.0, "kg")
    wheel_base_m: float = _between(
        0.4, "distance between the wheels (at most 2 radius_m)", 0.01, 10.0, "m"
    )
    wheel_radius_m: float = _between(0.08, "wheel radius", 0.005, 2.0, "m")
    max_wheel_speed_radps: float = _between(
        18.75, "top wheel speed (top speed = this x wheel_radius_m)", 0.1, 1000.0, "rad/s"
    )
    max_wheel_accel_radps2: float = _between(
        25.0, "wheel acceleration limit", 0.1, 10_000.0, "rad/s^2"
    )
    traction_mps2: float = _between(
        6.0, "motor force limit per kg: how hard a robot can push", 0.1, 100.0, "m/s^2"
    )

    def __post_init__(self) -> None:
        check_settings(self, self.SECTION)
        if self.wheel_base_m > 2.0 * self.radius_m:
            fail(
                "spatial.drive.wheel_base_m",
                "wheels must fit inside the robot (wheel_base_m <= 2 * radius_m)",
            )
        if not 0.01 <= self.max_speed_mps <= 50.0:
            fail(
                "spatial.drive.max_wheel_speed_radps",
                f"top speed {self.max_speed_mps:g} m/s (wheel speed x wheel radius) outside "
                "[0.01, 50] m/s",
            )

    @property
    def max_speed_mps(self) -> float:
        return self.max_wheel_speed_radps * self.wheel_radius_m


@dataclass(frozen=True, slots=True)
class LawSpec(_Section):
    """Steering toward the path, and the proximity law that keeps robots from ramming each
    other and the walls (``[spatial.law]``; with avoidance off it alone keeps robots apart)."""

    SECTION: ClassVar[str] = "spatial.law"
    heading_gain: float = _positive(
        2.5, "turn rate commanded per radian of heading error", 100, "1/s"
    )
    turn_in_place_deg: float = _between(
        60.0, "beyond this heading error a robot stops and turns in place", 0.01, 180.0, "deg"
    )
    creep_mps: float = _share(
        0.15, "closing speed still allowed on contact: robots may nudge, never ram", 10.0, "m/s"
    )
    keep_right_m: float = _share(
        0.6,
        "avoidance off: gap below which a robot turns right round one not going its way",
        10.0,
        "m",
    )
    keep_right_gain: float = _share(0.25, "that turn, as a share of the top turn rate")
    same_way_cos: float = setting(
        0.5, "a robot whose heading is within arccos(this) of ours goes our way", lo=-1.0, hi=1.0
    )
    proximity_decel: float = _positive(
        0.75, "share of the wheels' braking planned for around robots and walls", 1.0
    )
    react_periods: float = _between(
        1.0, "control periods a command holds before the next can brake", 0.01, 100.0
    )
    ahead_deg: float = _share(
        70.0, "a robot within this angle of the travel is in the way", 180.0, "deg"
    )
    speed_bound: float = setting(
        1.25, "no robot moves faster than this times the top speed, even pushed", lo=1.0, hi=10.0
    )
    turn_first_radps: float = _share(
        1.0, "avoidance on: a faster turn that must slow takes the wheels first", 1000.0, "rad/s"
    )

    @property
    def turn_in_place_rad(self) -> float:
        return math.radians(self.turn_in_place_deg)


@dataclass(frozen=True, slots=True)
class OrcaSpec(_Section):
    """Reciprocal collision avoidance (``[spatial.orca]``; used with ``avoidance = "orca"``)."""

    SECTION: ClassVar[str] = "spatial.orca"
    tau_s: float = _between(1.5, "time horizon toward other robots", 0.01, 60.0, "s")
    tau_obstacle_s: float = _between(
        0.6, "time horizon toward walls and obstacles", 0.01, 60.0, "s"
    )
    margin_m: float = _share(
        0.05, "added to the radius: a command is held one period while the robot turns", 1, "m"
    )
    wall_gap_m: float = _share(0.0, "air kept toward walls and obstacles", 1.0, "m")
    lane_air_m: float = _share(0.05, "air kept inside the free width of a single lane", 1.0, "m")
    lane_narrow_m: float = _share(
        1.0, "a path segment's free width below this is a single lane", 10.0, "m"
    )
    lane_near_m: float = _share(
        0.5, "... where a wall or obstacle is this close to the robot's body", 10.0, "m"
    )
    max_neighbours: int = setting(
        10, "nearest robots in range that give a half-plane", lo=1, hi=100
    )
    wall_lines: int = setting(
        4,
        "obstacle half-planes per robot: the nearest point of each obstacle edge in reach, "
        "nearest first, less points on or behind a nearer one's line (1: the nearest obstacle "
        "point only)",
        lo=1,
        hi=16,
    )
    back_share: float = _share(
        0.0, "share of the top speed a robot may reverse at to honour its half-planes"
    )
    robot_slack_mps: float = _share(
        0.005,
        "forward speed may close on a robot's line this fast when heading along it",
        1.0,
        "m/s",
    )
    wall_slack_mps: float = _share(0.005, "... on a wall's or lane's line", 1.0, "m/s")
    slack_shallow: float = _share(0.1, "'heading along a line': |normal . heading| below this")
    right_bias_deg: float = setting(
        30.0,
        "a robot with a binding half-plane prefers its velocity turned this far right",
        unit="deg",
        lo=0.0,
        hi=90.0,
        hi_open=True,
    )
    bias_room_m: float = _share(
        0.0,
        "the right-hand bias only where the body has more room than this to an obstacle "
        "(0: everywhere)",
        100.0,
        "m",
    )
    bias_meet_deg: float = setting(
        30.0,
        "the right-hand bias only in a meeting: a robot in the program lies within this angle "
        "of the robot's preferred velocity relative to that robot's velocity "
        "(180: every robot, as without the rule)",
        unit="deg",
        lo=0.0,
        hi=180.0,
    )
    bias_stand_s: float = _share(
        1.0,
        "... or the robot has made no progress along its path for this long "
        "(with bias_meet_deg below 180)",
        1000.0,
        "s",
    )


@dataclass(frozen=True, slots=True)
class FollowSpec(_Section):
    """Path following (``[spatial.follow]``)."""

    SECTION: ClassVar[str] = "spatial.follow"
    waypoint_switch_m: float = _share(
        0.2, "aim at the next waypoint once this close to the current one", 10.0, "m"
    )
    lookahead_m: float = _share(
        1.5, "a robot pushed off its path steers for the path this far ahead", 100.0, "m"
    )


@dataclass(frozen=True, slots=True)
class QueueSpec(_Section):
    """Service slots and queues at task sites (``[spatial.queue]``; avoidance on)."""

    SECTION: ClassVar[str] = "spatial.queue"
    slots: int = setting(4, "service slots on a ring round each service point", lo=0, hi=64)
    slot_gap_m: float = _share(
        0.35, "air a robot in a slot keeps to the one on the service point", 10.0, "m"
    )
    queue_m: float = _share(
        2.5, "a robot this close to a site with every place taken holds there", 100.0, "m"
    )
    crowd_m: float = _share(
        1.0, "... as does one this close to a robot already holding for the site", 100.0, "m"
    )
    exit_m: float = _share(
        1.5,
        "a robot that finished where others hold drives this far beyond queue_m out",
        100,
        "m",
    )
    exit_timeout_s: float = _positive(
        20.0, "... and gives up driving out after this long", 3600, "s"
    )
    hold_max_s: float = _positive(
        300.0, "a robot may hold in a queue this long before its task times out", 86_400.0, "s"
    )


@dataclass(frozen=True, slots=True)
class MakeWaySpec(_Section):
    """Idle robots stepping aside for driving ones (``[spatial.make_way]``)."""

    SECTION: ClassVar[str] = "spatial.make_way"
    trigger_m: float = _share(
        0.3,
        "a driving robot this close (beyond contact) to an idle one asks it to move",
        10,
        "m",
    )
    step_m: float = _share(1.0, "how far an idle robot steps aside", 10.0, "m")
    timeout_s: float = _positive(6.0, "an idle robot steps aside for at most this long", 3600, "s")
    pull_room_m: float = _share(
        1.0, "an idle robot with less room than this to an obstacle pulls over to it", 10.0, "m"
    )
    pull_gap_m: float = _share(
        0.15, "... leaving this much air between its body and the obstacle", 10.0, "m"
    )


@dataclass(frozen=True, slots=True)
class RecoverySpec(_Section):
    """Stuck robots (``[spatial.recovery]``; the time to stuck and the tries are
    ``[spatial] stuck_timeout_s`` and ``max_recoveries``)."""

    SECTION: ClassVar[str] = "spatial.recovery"
    backoff_s: float = _share(
        1.5, "a stuck robot reverses on a random arc this long, then replans", 60.0, "s"
    )
    avoid_turn_radps: float = _share(
        1.0,
        "with avoidance on, the back-off arc turns at most this fast (the speed caps take a"
        " robot's heading as held over a control period)",
        100.0,
        "rad/s",
    )
    recovered_m: float = _share(
        5.0,
        "this much closer to its site than where it got stuck, its tries start again",
        1000.0,
        "m",
    )
    detour_m: float = _share(
        1.0, "a robot blocked by one that stands still passes it this far to the side", 10, "m"
    )
    repair_wait_s: float = _share(
        300.0,
        "a robot whose only ways are blocked by broken robots waits this long",
        86_400.0,
        "s",
    )
    progress_m: float = _share(
        0.05, "less progress than this along the path does not reset the stuck clock", 10, "m"
    )


@dataclass(frozen=True, slots=True)
class JamSpec(_Section):
    """Jams between driving robots (``[spatial.jams]``; avoidance on)."""

    SECTION: ClassVar[str] = "spatial.jams"
    deadlock_m: float = _share(
        1.5, "driving robots this close, one of them stuck: a deadlock", 100.0, "m"
    )
    around_m: float = _share(
        3.0, "a stuck robot plans round the robots this close (centres)", 100.0, "m"
    )
    detour_factor: float = setting(
        3.0, "... and takes that path if at most this times the path it had ...", lo=1.0, hi=100.0
    )
    detour_extra_m: float = _share(10.0, "... plus this", 1000.0, "m")
    pass_s: float = _share(
        2.0, "a robot stood this long beside a driving robot acts on the jam", 3600.0, "s"
    )
    lane_gap_m: float = _share(
        0.1, "... where it cannot step this far beyond a robot's width aside", 10.0, "m"
    )
    pass_extra_m: float = _share(
        3.0, "beside a robot at work: take the path round it if at most this longer", 1000, "m"
    )
    ahead_block_m: float = _share(
        0.9, "look_ahead: a way passing this close to a robot at work is blocked", 10.0, "m"
    )
    ahead_wait_s: float = _share(
        2.0,
        "look_ahead: ... if that robot works this much longer when one gets there",
        3600,
        "s",
    )
    ahead_grow_m: float = _share(
        0.3, "look_ahead: the robot at work grown by this when planning round it", 10.0, "m"
    )


@dataclass(frozen=True, slots=True)
class TrafficSpec(_Section):
    """Traffic rules for single-lane passages (``[spatial.traffic]``; avoidance on): passages
    found from the geometry, entered under a directional lock (``sim.spatial.traffic``)."""

    SECTION: ClassVar[str] = "spatial.traffic"
    rules: str = setting(
        "on", "single-lane passages entered under a directional lock", choices=TRAFFIC_RULES
    )
    passage_m: float = _share(
        0.0,
        "a gap narrower than this is a single-lane passage (0: two lanes, "
        "2 (2 radius_m + 2 orca.margin_m) + 2 clearance_m)",
        100.0,
        "m",
    )
    chain_m: float = _share(
        2.5, "passages this close along a path are one chain, entered at once", 100.0, "m"
    )
    request_m: float = _share(
        1.2, "a robot asks for a passage this far before its mouth (along its path)", 100.0, "m"
    )
    hold_m: float = _share(
        0.35, "a robot kept out holds a radius plus this before the mouth", 10.0, "m"
    )
    aside_m: float = _share(
        0.7, "... moved this far aside of the lane where there is room", 10.0, "m"
    )
    exit_clear_m: float = _share(
        0.2,
        "entry only while a radius plus this of path beyond the exit is free of standing robots",
        10.0,
        "m",
    )
    release_m: float = _share(
        0.1, "a robot frees a passage once its centre is a radius plus this past it", 10.0, "m"
    )
    turn_s: float = _share(
        10.0,
        "after this much opposing wait no robot enters a passage the way it is used",
        3600.0,
        "s",
    )
    hold_max_s: float = _positive(
        60.0,
        "a robot kept out this long drives on without the lock (the jam rules apply)",
        3600,
        "s",
    )
    at_work: str = setting(
        "on",
        "a robot at work that leaves less than two lanes beside it makes a temporary passage",
        choices=TRAFFIC_RULES,
    )


@dataclass(frozen=True, slots=True)
class StallSpec(_Section):
    """The stall meter: where driving robots stand still and why (``[spatial.stalls]``)."""

    SECTION: ClassVar[str] = "spatial.stalls"
    still_mps: float = _share(
        0.1, "a driving robot commanded slower than this stands still", 10, "m/s"
    )
    near_m: float = _share(1.2, "the nearest robot counts within this (centres)", 100.0, "m")
    long_s: float = _share(2.0, "standing beyond this much of a stand counts as long", 3600, "s")
    map_cell_m: float = _positive(0.5, "cell side of the map of where robots stand", 100.0, "m")


@dataclass(frozen=True, slots=True)
class ContactSpec(_Section):
    """The contact solver and how contacts are counted (``[spatial.contacts]``)."""

    SECTION: ClassVar[str] = "spatial.contacts"
    impact_mps: float = _share(
        0.3,
        "a contact begun at this closing speed or more is an impact, else a touch",
        100,
        "m/s",
    )
    iterations: int = setting(
        10, "solver iterations while any contact touches (pymunk's default)", lo=1, hi=1000
    )
    free_iterations: int = setting(
        1,
        "solver iterations while none does (the motor joints alone: one is exact)",
        lo=1,
        hi=1000,
    )


@dataclass(frozen=True, slots=True)
class SpatialSpec:
    """Arena, obstacles and task sites of a spatial world, and every rule of its robots."""

    SECTION: ClassVar[str] = "spatial"
    width_m: float = required("arena width (x)", unit="m", lo=0.0, lo_open=True, hi=MAX_ARENA_M)
    height_m: float = required("arena height (y)", unit="m", lo=0, lo_open=True, hi=MAX_ARENA_M)
    obstacles: tuple[tuple[tuple[float, float], ...], ...] = ()  # convex polygons, m
    sites: tuple[tuple[tuple[float, float], ...], ...] = ()  # per task type: task points, m
    drive: DriveSpec = table(DriveSpec, "the robot body")
    dt_s: float = _between(
        1.0 / 60.0,
        "physics time step (too coarse above 0.05, too costly below 1e-4)",
        1e-4,
        0.05,
        "s",
    )
    control_hz: float = setting(
        20.0,
        "control rate (at most 1 / dt_s; robots overshoot below 2)",
        unit="Hz",
        lo=2.0,
        hi=1000.0,
    )
    arrive_tol_m: float = _positive(
        0.3, "a robot this close to its task point has arrived", 10, "m"
    )
    grid_res_m: float = _between(
        0.25, "cell side of the occupancy grid (drawing only)", 0.01, 10.0, "m"
    )
    stuck_timeout_s: float = _positive(
        20.0, "a robot without progress this long is stuck (backs off and replans)", 3600.0, "s"
    )
    clearance_m: float = _share(
        0.1, "planned paths keep this much space beyond the robot radius", 10.0, "m"
    )
    max_recoveries: int = setting(
        3, "back-off-and-replan tries before a task is reported failed", lo=0, hi=1000
    )
    collision_slop_m: float = setting(
        0.005, "pymunk's allowed overlap", unit="m", lo=0.0, hi=0.05, hi_open=True
    )
    avoidance: str = setting(
        "orca", "collision avoidance: ORCA, or none (the proximity law alone)", choices=AVOIDANCE
    )
    look_ahead: str = setting(
        "on", "plan round robots at work in the way when a task is given", choices=LOOK_AHEAD
    )
    law: LawSpec = table(LawSpec, "steering and the proximity law")
    orca: OrcaSpec = table(OrcaSpec, "collision avoidance")
    follow: FollowSpec = table(FollowSpec, "path following")
    queue: QueueSpec = table(QueueSpec, "site slots and queues")
    make_way: MakeWaySpec = table(MakeWaySpec, "idle robots stepping aside")
    recovery: RecoverySpec = table(RecoverySpec, "stuck robots")
    jams: JamSpec = table(JamSpec, "jams between driving robots")
    traffic: TrafficSpec = table(TrafficSpec, "traffic rules for single-lane passages")
    stalls: StallSpec = table(StallSpec, "the stall meter")
    contacts: ContactSpec = table(ContactSpec, "the contact solver")
    # The ROS map the arena and obstacles came from ("" for none), as a resolved path: the
    # loader fills the arena from it (``scenarios.loader.map_arena``); drawings show its cells.
    map: str = ""

    def __post_init__(self) -> None:
        check_settings(self, self.SECTION)
        for name in _TABLES:
            cls = type(self).__dataclass_fields__[name].default_factory
            if not isinstance(getattr(self, name), cls):
                got = kind_of(getattr(self, name))
                fail(f"spatial.{name}", f"must be a {cls.__name__}, got {got}")
        if self.control_hz * self.dt_s > 1.0:
            fail(
                "spatial.control_hz",
                f"control ({self.control_hz:g} Hz) cannot run faster than physics (1/dt_s)",
            )
        if not isinstance(self.map, str):
            fail("spatial.map", f"must be a file name, got {kind_of(self.map)}")
        if self.width_m * self.height_m > MAX_GRID_CELLS * self.grid_res_m**2:
            fail("spatial.grid_res_m", f"the grid would have more than {MAX_GRID_CELLS:,} cells")
        object.__setattr__(self, "obstacles", self._obstacles(self.obstacles))
        if self.map:
            check_map_arena(self)

    @classmethod
    def on_map(
        cls, path: str | Path, *, sites: Any = (), obstacles: Any = (), **settings: Any
    ) -> SpatialSpec:
        """The ``[spatial]`` table of a scenario on a ROS map, as a file with ``map = path``
        gives it: the arena and obstacles of the map (:func:`sim.scenario.maps.map_arena`),
        ``sites`` (per task type) and extra convex ``obstacles`` in the map's frame, any other
        setting as a keyword. Robot starts move to the world's frame with
        ``map_arena(path).to_world((x, y))``."""
        for key in ("width_m", "height_m", "map"):
            if key in settings:
                fail(f"spatial.{key}", "not allowed beside spatial.map: the map sets the arena")
        arena = map_arena(path)
        own = shifted_points(obstacles, arena.origin_xy, depth=2)
        return cls(
            width_m=arena.width_m,
            height_m=arena.height_m,
            obstacles=(*own, *arena.polygons) if isinstance(own, list) else own,
            sites=tuple(tuple(shifted_points(pts, arena.origin_xy)) for pts in sites),
            map=arena.path,
            **settings,
        )

    @property
    def avoid(self) -> bool:
        """True with collision avoidance on (``avoidance = "orca"``)."""
        return self.avoidance == "orca"

    def _obstacles(self, raw: Any) -> tuple:
        """Convex polygons inside the arena, counter-clockwise (as the planner expects)."""
        if not isinstance(raw, list | tuple):
            fail("spatial.obstacles", "must be a list of polygons [[x, y], ...]")
        out = []
        for k, poly in enumerate(raw):
            where = f"spatial.obstacles[{k}]"
            if not isinstance(poly, list | tuple | np.ndarray) or len(poly) < 3:
                fail(where, "must be a polygon of at least 3 points [[x, y], ...]")
            pts = np.array([point(p, f"{where}[{i}]") for i, p in enumerate(poly)])
            for i, (x, y) in enumerate(pts):
                if not (0.0 <= x <= self.width_m and 0.0 <= y <= self.height_m):
                    fail(f"{where}[{i}]", f"vertex ({x:g}, {y:g}) outside the arena")
            edge = np.roll(pts, -1, axis=0) - pts
            nxt = np.roll(edge, -1, axis=0)
            cross = edge[:, 0] * nxt[:, 1] - edge[:, 1] * nxt[:, 0]
            if not ((cross > 1e-12).all() or (cross < -1e-12).all()):
                fail(where, "must be convex, with no repeated or collinear vertices")
            if cross[0] < 0:
                pts = pts[::-1]
            turning = np.arctan2(cross, (edge * nxt).sum(axis=1))
            if abs(abs(turning.sum()) - 2 * math.pi) > 1e-6:
                fail(where, "must be a simple convex polygon (it winds more than once)")
            out.append(tuple(map(tuple, pts.tolist())))
        return tuple(out)

    def site_points(self, raw: Any, where: str) -> tuple[tuple[float, float], ...]:
        """One task type's site points, checked (``where``: ``spatial.sites.T1``)."""
        if not isinstance(raw, list | tuple | np.ndarray) or not len(raw):
            fail(where, "must be a non-empty list of points [[x, y], ...]")
        if len(raw) > MAX_SITES:
            fail(where, f"{len(raw)} sites, more than the {MAX_SITES} we support")
        pts = tuple(point(p, f"{where}[{i}]") for i, p in enumerate(raw))
        for i, (x, y) in enumerate(pts):
            if not (0.0 <= x <= self.width_m and 0.0 <= y <= self.height_m):
                fail(f"{where}[{i}]", f"({x:g}, {y:g}) outside the arena")
        return pts


_TABLES = ("drive", "law", "orca", "follow", "queue", "make_way", "recovery", "jams", "stalls")
_TABLES += ("contacts", "traffic")


def point(val: Any, where: str) -> tuple[float, float]:
    """A finite point ``[x, y]`` (m), or ScenarioError naming ``where``."""
    if isinstance(val, str) or not isinstance(val, list | tuple | np.ndarray) or len(val) != 2:
        fail(where, "must be a point [x, y]")
    out = []
    for i, x in enumerate(val):
        if isinstance(x, bool) or not isinstance(x, int | float | np.number):
            fail(f"{where}[{i}]", f"must be a number, got {kind_of(x)}")
        x = float(x)
        if not math.isfinite(x):
            fail(f"{where}[{i}]", f"must be finite, got {x}")
        out.append(x)
    return out[0], out[1]


__all__ = [
    "AVOIDANCE",
    "LOOK_AHEAD",
    "MAX_GRID_CELLS",
    "MAX_SITES",
    "TRAFFIC_RULES",
    "ContactSpec",
    "DriveSpec",
    "FollowSpec",
    "JamSpec",
    "LawSpec",
    "MakeWaySpec",
    "OrcaSpec",
    "QueueSpec",
    "RecoverySpec",
    "SpatialSpec",
    "StallSpec",
    "TrafficSpec",
    "point",
]
