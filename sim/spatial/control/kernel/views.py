"""The kernel's arguments from the world's objects, as plain tuples (numba types a plain
tuple at each call several times faster than a named one): one builder each, used by the
control period and by the warm-up alike, so that the compiled code always sees the same types.
The order of each tuple is the order of the named tuple the kernel makes of it. This module
does not import numba (a process without a pymunk world never does)."""

from __future__ import annotations

import numpy as np


def fleet_of(f) -> tuple:
    """``steering.Fleet`` of a ``FleetState`` (taken afresh each time: a collaborator may have
    replaced an array)."""
    return (
        f.state,
        f.yielding,
        f.yield_until_s,
        f.backoff_until_s,
        f.backoff_cmd,
        f.progress_m,
        f.t_progress_s,
        f.stuck_left_m,
        f.left_m,
        f.v_cmd_mps,
        f.q_cmd_mps,
        f.last_z_m,
        f.last_th_rad,
        f.moved_m,
    )


def sites_of(parts) -> tuple:
    """``quiet.Sites`` of the world's parts (``ControlParts``; afresh: a restore replaces the
    sites' arrays)."""
    f, sites = parts.fleet, parts.jobs.sites
    rules, r = sites.rules, sites.controller.radius_m
    return (
        float(rules.queue_m),
        float(rules.crowd_m),
        float(parts.arrive_tol_m),
        float(parts.arrive_tol_m + 2 * parts.reach_m),
        float(2.0 * r + 0.5 * rules.slot_gap_m),
        f.site,
        sites.service,
        sites.admitted,
        sites.holding,
        sites.slotted,
        sites.blocked,
        sites.held,
        sites.broken,
        f.replan,
        float(parts.jobs.spatial.stuck_timeout_s),
    )


def follower_of(fol) -> tuple:
    """``steering.Follower`` of a ``PathFollower`` (afresh: a longer path regrows arrays)."""
    return (
        fol.points,
        fol.last,
        fol.index,
        fol.after_m,
        fol.corner2,
        fol.free_m,
        fol.capped_m,
        fol.tgt_,
        fol.unit_c_,
        fol.seg_m_,
        fol.after_,
        fol.corner2_,
        fol.switch_,
        fol.beyond_,
        fol.free_,
        fol.capped_,
    )


def poses_for(m: int) -> tuple:
    """``steering.Poses`` buffers for ``m`` robots: z, h, th, vel."""
    return (np.zeros(m, complex), np.ones(m, complex), np.zeros(m), np.zeros(m, complex))


def wishes_for(m: int) -> tuple:
    """``steering.Wishes`` buffers for ``m`` robots: v, w, pref, go, stop, past."""
    flags = [np.zeros(m, dtype=bool) for _ in range(3)]
    return (np.zeros(m), np.zeros(m), np.zeros(m, complex), *flags)


def kept_for(m: int) -> tuple:
    """What the kernel keeps between its calls: ORCA's flags, and where each robot's distance
    to the nearest obstacle was measured and that distance (-inf: never)."""
    return (np.zeros(m, dtype=bool), np.zeros(m, complex), np.full(m, -np.inf))


def outputs_for(m: int) -> tuple:
    """Fresh output arrays of one period: v, w, q, blocker, near, push."""
    return (
        np.empty(m),
        np.empty(m),
        np.empty(m),
        np.empty(m, dtype=np.int64),
        np.empty(m),
        np.empty(m, dtype=bool),
    )


def edges_of(follower, reach_m: float = 0.0) -> tuple:
    """``obstacles.Edges`` of a ``PathFollower``: its obstacle edges and their grid (empty
    tables without one), with the edges each cell can have within ``reach_m`` (0: no such
    table; ``EdgeCells.within``)."""
    e0 = np.ascontiguousarray(follower.edge0_, dtype=complex)
    d = np.ascontiguousarray(follower.edge1_ - follower.edge0_, dtype=complex)
    cells = follower.cells_
    empty = np.zeros((0, 0), dtype=np.int64)
    if cells is None:
        none = np.zeros(0, dtype=complex)
        return (e0, d, none, none, empty, 0j, 0.0, 0, 0, empty)
    reach = empty if reach_m <= 0.0 else cells.within(reach_m)
    return (
        e0,
        d,
        np.ascontiguousarray(cells.e0, dtype=complex),
        np.ascontiguousarray(cells.d, dtype=complex),
        np.ascontiguousarray(cells.table, dtype=np.int64),
        complex(cells.lo),
        float(cells.inv),
        int(cells.nx),
        int(cells.ny),
        np.ascontiguousarray(reach, dtype=np.int64),
    )


def shapes_of(follower) -> tuple:
    """``freewidth.Shapes`` of a ``PathFollower``: its obstacles' vertices and edges."""
    return (
        np.ascontiguousarray(follower.verts_, dtype=complex),
        np.ascontiguousarray(follower.vert_start_, dtype=np.int64),
        np.ascontiguousarray(follower.edge0_, dtype=complex),
        np.ascontiguousarray(follower.edge1_, dtype=complex),
        np.ascontiguousarray(follower.edge_start_, dtype=np.int64),
    )
