"""Vertices and volume of a strip polytope cut by a box and by extra halfspaces (gaps found by the
mutation run: no test had a box face or a halfspace face on P)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection

from boundid.sets import Polytope


def brute_vertices(H, h):
    """Vertices of {H x <= h} by scipy HalfspaceIntersection on all rows, interior point from a
    plain scipy linprog Chebyshev LP: an independent implementation (no screening, no scaling)."""
    nrm = np.linalg.norm(H, axis=1)
    p = H.shape[1]
    res = linprog(np.r_[np.zeros(p), -1.0], A_ub=np.hstack([H, nrm[:, None]]), b_ub=h,
                  bounds=[(None, None)] * p + [(0, None)], method="highs")
    assert res.status == 0 and res.x[-1] > 1e-6
    return HalfspaceIntersection(np.hstack([H, -h[:, None]]), res.x[:-1]).intersections


def _same_points(A, B, tol):
    d = np.linalg.norm(A[:, None, :] - B[None, :, :], axis=2)
    return len(A) == len(B) and np.all(d.min(axis=1) < tol) and np.all(d.min(axis=0) < tol)


@pytest.mark.parametrize("p,seed", [(2, 0), (3, 1)])
def test_vertices_and_volume_with_box_and_halfspaces(p, seed):
    """Reference: scipy HalfspaceIntersection + ConvexHull on every strip side, box side and
    halfspace. The box cuts P on both sides of parameter 0 and one halfspace cuts a corner, so
    box faces and halfspace faces are faces of P (vertices to 1e-7, volume to 1e-7 relative)."""
    rng = np.random.default_rng(seed)
    theta = rng.normal(size=p)
    W = rng.normal(size=(12 * p, p))
    e = np.full(len(W), 0.6)
    y = W @ theta + 0.5 * e * rng.uniform(-1, 1, len(W))
    free = Polytope(W, y, e).bounds()
    c, hw = free.center, free.half_width
    lo = np.full(p, -np.inf)
    hi = np.full(p, np.inf)
    lo[0], hi[0] = c[0] - 0.5 * hw[0], c[0] + 0.4 * hw[0]       # cut on both sides
    a = np.ones(p) / np.sqrt(p)
    b = a @ c + 0.3 * np.abs(a) @ hw                               # cut one corner
    P = Polytope(W, y, e, box=(lo, hi), halfspaces=(a[None, :], [b]))
    H = np.vstack([W, -W, np.eye(p)[:1], -np.eye(p)[:1], a[None, :]])
    h = np.concatenate([y + e, e - y, hi[:1], -lo[:1], [b]])
    V = brute_vertices(H, h)
    assert _same_points(P.vertices(), V, 1e-7)
    assert P.volume() == pytest.approx(ConvexHull(V).volume, rel=1e-7)
    # the cuts are active: the box and the halfspace each hold vertices of P
    assert np.any(np.isclose(V[:, 0], lo[0])) and np.any(np.isclose(V[:, 0], hi[0]))
    assert np.any(np.isclose(V @ a, b))


def test_one_dimensional_vertices_are_the_interval_ends():
    """Closed form: in 1-D, P is [max(y - e)/w, min(y + e)/w] for w > 0; vertices() lists lo then hi."""
    w = np.array([[1.0], [2.0], [0.5]])
    y = np.array([1.0, 2.2, 0.45])
    e = np.array([0.3, 0.4, 0.2])
    lo, hi = np.max((y - e) / w[:, 0]), np.min((y + e) / w[:, 0])
    V = Polytope(w, y, e).vertices()
    assert V.shape == (2, 1)
    assert V[0, 0] == pytest.approx(lo, abs=1e-9) and V[1, 0] == pytest.approx(hi, abs=1e-9)
