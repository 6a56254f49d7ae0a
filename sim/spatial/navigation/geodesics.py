"""All-pairs shortest paths in the planner's visibility graph, compiled: scipy's Dijkstra,
step for step, without the sparse matrices.

scipy (``scipy.sparse.csgraph.dijkstra``, undirected) runs one search per source with a
priority queue of (distance, vertex) pairs: it pops the least distance, and of equal
distances the highest vertex index (C++'s ``priority_queue`` of ``pair(-distance,
index)``), skips a vertex popped with a distance it has since bettered, and relaxes a
vertex's neighbours in the order of the graph's row (the pairs i < j, j rising) and then of
its transpose's row (i rising), keeping the first predecessor that reaches a distance
(a strictly shorter one replaces it). Pops of equal pairs cannot be told apart, so every
heap that keeps that order pops the same vertices in the same order, and the same sums are
formed in the same order: distances and predecessors are scipy's bit for bit, ties
included (tests/sim/spatial/navigation/test_geodesics.py). The edge weights are the
planner's (``np.linalg.norm`` of the pair's difference plus 1e-12, which keeps coincident
vertices joined), computed as numpy computes them.

For a visibility graph of tens of vertices, as :meth:`GridPlanner.path_around` builds per
call, building scipy's sparse matrices cost as much as the search; this builds nothing.
"""

from __future__ import annotations

import math

import numba
import numpy as np

NO_PREDECESSOR = -9999  # scipy's value where a vertex has no predecessor


@numba.njit(cache=True, nogil=True)
def _sift_up(keys: np.ndarray, items: np.ndarray, k: int) -> None:
    """Restore the heap order above slot k (the least distance, then the highest index, on
    top)."""
    key, item = keys[k], items[k]
    while k > 0:
        parent = (k - 1) // 2
        pk, pi = keys[parent], items[parent]
        if pk < key or (pk == key and pi > item):
            break
        keys[k], items[k] = pk, pi
        k = parent
    keys[k], items[k] = key, item


@numba.njit(cache=True, nogil=True)
def _sift_down(keys: np.ndarray, items: np.ndarray, size: int) -> None:
    """Restore the heap order below the top slot."""
    k = 0
    key, item = keys[0], items[0]
    while True:
        child = 2 * k + 1
        if child >= size:
            break
        right = child + 1
        if right < size:
            rk, ck = keys[right], keys[child]
            if rk < ck or (rk == ck and items[right] > items[child]):
                child = right
        ck, ci = keys[child], items[child]
        if key < ck or (key == ck and item > ci):
            break
        keys[k], items[k] = ck, ci
        k = child
    keys[k], items[k] = key, item


@numba.njit(cache=True, nogil=True)
def visibility_geodesics(
    vertices: np.ndarray, i: np.ndarray, j: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Shortest paths between every pair of ``vertices`` ((V, 2), m) over the straight edges
    ``i[e] -- j[e]`` (i < j, row by row, columns rising: ``np.triu_indices`` order, a subset
    of it): ``(dist, pred)``, (V, V) each; ``dist[s, t]`` is inf and ``pred[s, t]``
    :data:`NO_PREDECESSOR` where t cannot be reached from s (and ``pred[s, s]``)."""
    nv, ne = vertices.shape[0], i.shape[0]
    weight = np.empty(ne)
    for e in range(ne):
        dx = vertices[i[e], 0] - vertices[j[e], 0]
        dy = vertices[i[e], 1] - vertices[j[e], 1]
        weight[e] = math.sqrt(dx * dx + dy * dy) + 1e-12
    # each vertex's neighbours: those above it (its row), then those below (its column)
    degree = np.zeros(nv, dtype=np.int64)
    for e in range(ne):
        degree[i[e]] += 1
        degree[j[e]] += 1
    start = np.zeros(nv + 1, dtype=np.int64)
    for v in range(nv):
        start[v + 1] = start[v] + degree[v]
    fill = start[:-1].copy()
    nbr = np.empty(2 * ne, dtype=np.int64)
    nbr_w = np.empty(2 * ne)
    for e in range(ne):  # rows: pairs come i rising, j rising within a row
        a = i[e]
        nbr[fill[a]], nbr_w[fill[a]] = j[e], weight[e]
        fill[a] += 1
    for e in range(ne):  # columns: for a fixed j the pairs come with i rising
        b = j[e]
        nbr[fill[b]], nbr_w[fill[b]] = i[e], weight[e]
        fill[b] += 1
    dist = np.full((nv, nv), math.inf)
    pred = np.full((nv, nv), NO_PREDECESSOR, dtype=np.int32)
    keys = np.empty(2 * ne + 1)
    items = np.empty(2 * ne + 1, dtype=np.int64)
    for s in range(nv):
        d, p = dist[s], pred[s]
        d[s] = 0.0
        keys[0], items[0] = 0.0, s
        size = 1
        while size:
            at, v = keys[0], items[0]
            size -= 1
            if size:
                keys[0], items[0] = keys[size], items[size]
                _sift_down(keys, items, size)
            if d[v] < at:
                continue  # bettered since it was pushed
            for k in range(start[v], start[v + 1]):
                u = nbr[k]
                nxt = at + nbr_w[k]
                if d[u] > nxt:
                    d[u] = nxt
                    p[u] = v
                    keys[size], items[size] = nxt, u
                    _sift_up(keys, items, size)
                    size += 1
    return dist, pred
