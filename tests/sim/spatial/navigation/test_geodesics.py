"""The compiled all-pairs search (``sim.spatial.navigation.geodesics``) gives scipy's
distances and predecessors bit for bit: on random graphs with ties (vertices on a grid,
coincident ones, missing edges, parts that cannot reach each other) and on the visibility
graphs of the bundled arenas and a map."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from scenarios.loader import load_scenario
from sim.spatial.navigation.geodesics import NO_PREDECESSOR, visibility_geodesics
from sim.spatial.navigation.planning import GridPlanner

TB3 = Path(__file__).parents[3] / "scenarios" / "maps" / "tb3_sandbox.toml"


def scipy_geodesics(v: np.ndarray, i: np.ndarray, j: np.ndarray):
    """The planner's graph as scipy's sparse rows, searched by scipy (the reference)."""
    nv = len(v)
    w = np.linalg.norm(v[i] - v[j], axis=1) + 1e-12
    indptr = np.zeros(nv + 1, dtype=np.int32)
    np.cumsum(np.bincount(i, minlength=nv), out=indptr[1:])
    graph = csr_matrix((w, j.astype(np.int32), indptr), shape=(nv, nv))
    return dijkstra(graph, directed=False, return_predecessors=True)


def assert_same(got, want) -> None:
    (d1, p1), (d0, p0) = got, want
    assert d1.dtype == d0.dtype and p1.dtype == p0.dtype
    np.testing.assert_array_equal(d1.view(np.uint64), d0.view(np.uint64))
    np.testing.assert_array_equal(p1, p0)


@pytest.mark.parametrize("grid", [False, True])
def test_random_graphs_give_scipys_numbers_bit_for_bit(grid):
    rng = np.random.default_rng(3)
    ties = unreachable = 0
    for _ in range(600):
        nv = int(rng.integers(1, 30))
        if grid:  # many equal lengths and coincident vertices
            v = rng.integers(0, 4, (nv, 2)).astype(float)
        else:
            v = rng.uniform(0, 10, (nv, 2))
        i, j = np.triu_indices(nv, k=1)
        keep = rng.random(len(i)) < rng.uniform(0.05, 1.0)
        want = scipy_geodesics(v, i[keep], j[keep])
        assert_same(visibility_geodesics(v, i[keep], j[keep]), want)
        unreachable += bool(np.isinf(want[0]).any())
        finite = want[0][np.isfinite(want[0])]
        ties += len(finite) - len(np.unique(finite))
    assert unreachable > 50
    if grid:
        assert ties > 1000  # the cases where the order of the search decides


def test_no_vertex_and_one_vertex():
    empty = np.zeros((0, 2))
    none = np.zeros(0, dtype=np.int64)
    d, p = visibility_geodesics(empty, none, none)
    assert d.shape == p.shape == (0, 0)
    d, p = visibility_geodesics(np.ones((1, 2)), none, none)
    assert d.tolist() == [[0.0]] and p.tolist() == [[NO_PREDECESSOR]]


def test_a_square_goes_round_by_the_first_way_found():
    # 0 (0,0), 1 (1,0), 2 (0,1), 3 (1,1); edges round the square only: 0 -> 3 is 2 m either
    # way; scipy pops vertex 2 before 1 (equal distance, higher index), so 3 comes from 2
    v = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    i, j = np.array([0, 0, 1, 2]), np.array([1, 2, 3, 3])
    d, p = visibility_geodesics(v, i, j)
    assert d[0, 3] == pytest.approx(2.0) and p[0, 3] == 2
    assert_same((d, p), scipy_geodesics(v, i, j))


@pytest.mark.parametrize("scenario", ["paper_spatial", "warehouse", "depot", str(TB3)])
def test_the_planners_graphs_give_scipys_numbers(scenario):
    planner = GridPlanner(load_scenario(scenario).spatial)
    nv = len(planner.vertices_)
    i, j = np.triu_indices(nv, k=1)
    ok = planner.seen_
    assert nv > 10 and ok.any()
    assert_same((planner.apsp_, planner.pred_), scipy_geodesics(planner.vertices_, i[ok], j[ok]))
