"""The blocked cells of a grid as closed boundary loops, on the lattice of cell corners.

Blocked cells are grouped 8-connected (cells touching at a corner belong together, so a
diagonal wall one cell thick is one piece) and free cells 4-connected, the pairing under which
every blocked component has exactly one outer boundary and one inner boundary (hole) per
enclosed free component. Each loop follows the cell edges between blocked and free cells, with
blocked on its left: outer loops run counter-clockwise, holes clockwise. Cells beyond the grid
count as free here (the arena's walls stand there), so a component touching the border is
closed along it.

Where two blocked cells touch only at a corner (a *saddle*), the loop would pass through that
corner twice; instead it cuts each of the two free cells' corners there by half a cell, so
every loop is a simple polygon and the two sides of a diagonal wall keep a neck of
sqrt(2) / 2 cells between them. Coordinates are integers in half cells from the grid's lower-left
corner (x = 2 i at the left edge of column i), so all later geometry is exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from sim.maps.lattice import area2

EIGHT = ((1, 1, 1), (1, 1, 1), (1, 1, 1))  # scipy.ndimage structure: 8-connectivity
STEPS = ((1, 0), (0, 1), (-1, 0), (0, -1))  # directions E, N, W, S (counter-clockwise)


@dataclass(frozen=True, slots=True)
class Cleaned:
    """A blocked mask after dropping specks and filling pockets, and what that changed."""

    blocked: np.ndarray  # (ny, nx) bool
    specks: int  # blocked components dropped
    speck_cells: int
    pockets: int  # enclosed free components filled
    pocket_cells: int


def clean_blocked(
    blocked: np.ndarray, min_speck_cells: float, min_pocket_cells: float, fill_detached: bool
) -> Cleaned:
    """Drop blocked components (8-connected) of fewer than ``min_speck_cells`` cells and fill
    free components (4-connected) that do not touch the grid's border and have fewer than
    ``min_pocket_cells`` cells (such a pocket is enclosed by one blocked component); with
    ``fill_detached``, fill every free component but the largest too."""
    out = np.array(blocked, dtype=bool)
    labels, n = ndimage.label(out, structure=EIGHT)
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    small = sizes < min_speck_cells
    small[0] = False
    out[small[labels]] = False
    speck_cells = int(sizes[small].sum())
    labels, n = ndimage.label(~out)
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    fill = sizes < min_pocket_cells
    edge = np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])
    fill[edge] = False
    if fill_detached and n > 1:
        fill[:] = True
        fill[1 + int(np.argmax(sizes[1:]))] = False
    fill[0] = False
    out[fill[labels]] = True
    return Cleaned(
        blocked=out,
        specks=int(small.sum()),
        speck_cells=speck_cells,
        pockets=int(fill.sum()),
        pocket_cells=int(sizes[fill].sum()),
    )


@dataclass(frozen=True, slots=True)
class Loop:
    """One boundary: its corners (k, 2) in half cells and the blocked component it bounds."""

    points: np.ndarray  # (k, 2) int64, closed implicitly (last joins first)
    component: int  # label of the blocked component (1-based, 8-connected)
    outer: bool  # True: the component's outline (counter-clockwise); False: a hole (clockwise)


def trace_loops(blocked: np.ndarray) -> tuple[list[Loop], int]:
    """Every boundary loop of the blocked cells, and the number of blocked components.

    Runs of collinear unit edges are merged, so a loop has one point per corner (two per
    saddle: the cut).
    """
    ny, nx = blocked.shape
    pad = np.zeros((ny + 2, nx + 2), dtype=bool)
    pad[1:-1, 1:-1] = blocked
    labels, n = ndimage.label(pad, structure=EIGHT)
    runs = _runs(pad)
    if runs is None:
        return [], n
    start, end, direction = runs
    width = nx + 3  # lattice vertices per row (padded grid)
    skey = start[:, 1] * width + start[:, 0]
    ekey = end[:, 1] * width + end[:, 0]
    order = np.argsort(skey, kind="stable")
    first = np.searchsorted(skey[order], ekey, side="left")
    last = np.searchsorted(skey[order], ekey, side="right")
    nxt = order[first]
    saddle = (last - first) == 2
    right = (direction - 1) % 4  # at a saddle, turn right: keeps the corner-touching cells joined
    other = order[np.minimum(first + 1, len(order) - 1)]
    pick_other = saddle & (direction[nxt] != right)
    nxt = np.where(pick_other, other, nxt)
    left_cell = _left_cells(start, direction)
    component = labels[left_cell[:, 0], left_cell[:, 1]]
    loops = []
    seen = [False] * len(start)
    nxt_list = nxt.tolist()
    for r0 in range(len(start)):
        if seen[r0]:
            continue
        chain = []
        r = r0
        while not seen[r]:
            seen[r] = True
            chain.append(r)
            r = nxt_list[r]
        idx = np.array(chain)
        pts = _corners(end[idx], direction[idx], direction[nxt[idx]], saddle[idx])
        pts = pts - 2  # drop the padding: one cell is two half cells
        loops.append(Loop(pts, int(component[r0]), area2(pts) > 0))
    return loops, n


def _runs(pad: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Maximal straight runs of boundary edges: start and end vertices (R, 2) (x, y in cells of
    the padded grid) and direction (R,) 0..3 (E, N, W, S), blocked on the left."""
    starts, ends, dirs = [], [], []
    # horizontal edges on the line y = j + 1, between the cells of rows j (below) and j + 1
    below, above = pad[:-1, :], pad[1:, :]
    for d, mask in ((0, above & ~below), (2, below & ~above)):
        j, i0, i1 = _segments(mask)
        y = j + 1
        if d == 0:
            starts.append(np.column_stack([i0, y]))
            ends.append(np.column_stack([i1, y]))
        else:
            starts.append(np.column_stack([i1, y]))
            ends.append(np.column_stack([i0, y]))
        dirs.append(np.full(len(j), d))
    # vertical edges on the line x = i + 1, between the cells of columns i (left) and i + 1
    left, right = pad[:, :-1], pad[:, 1:]
    for d, mask in ((1, left & ~right), (3, right & ~left)):
        i, j0, j1 = _segments(mask.T)
        x = i + 1
        if d == 1:
            starts.append(np.column_stack([x, j0]))
            ends.append(np.column_stack([x, j1]))
        else:
            starts.append(np.column_stack([x, j1]))
            ends.append(np.column_stack([x, j0]))
        dirs.append(np.full(len(i), d))
    start = np.concatenate(starts).astype(np.int64)
    if not len(start):
        return None
    return start, np.concatenate(ends).astype(np.int64), np.concatenate(dirs)


def _segments(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Runs of True along each row of ``mask``: (row, first column, last column + 1)."""
    padded = np.zeros((mask.shape[0], mask.shape[1] + 2), dtype=np.int8)
    padded[:, 1:-1] = mask
    change = np.diff(padded, axis=1)
    rows, first = np.nonzero(change == 1)
    _, after = np.nonzero(change == -1)  # row-major order: the k-th end closes the k-th start
    return rows, first, after


def _left_cells(start: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """(R, 2) [row, col] in the padded grid of the blocked cell left of each run's first edge."""
    x, y = start[:, 0], start[:, 1]
    row = np.select([direction == 0, direction == 1, direction == 2], [y, y, y - 1], y - 1)
    col = np.select([direction == 0, direction == 1, direction == 2], [x, x - 1, x - 1], x)
    return np.column_stack([row, col])


def _corners(
    end: np.ndarray, d_in: np.ndarray, d_out: np.ndarray, saddle: np.ndarray
) -> np.ndarray:
    """The loop's points in half cells: each run's end, or at a saddle the two cut points."""
    at = 2 * end
    plain = ~saddle
    step = np.array(STEPS, dtype=np.int64)
    before = at - step[d_in]
    after = at + step[d_out]
    count = np.where(plain, 1, 2)
    out = np.empty((int(count.sum()), 2), dtype=np.int64)
    pos = np.cumsum(count) - count
    out[pos[plain]] = at[plain]
    out[pos[saddle]] = before[saddle]
    out[pos[saddle] + 1] = after[saddle]
    return out
