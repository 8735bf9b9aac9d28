"""Polytopes known by their vertices (and facets), for small p; 2-D ones are polygons.

:class:`VertexPolytope` is the set of the exact recursive polytope estimator (p <= 4) and the
exact shadow of any polytope on a coordinate plane. :func:`shadow` computes that shadow for an
H-polytope known only through an LP support oracle (``support_point``, e.g.
:meth:`boundid.sets.Polytope.support_point`).
"""

from __future__ import annotations

from collections import deque

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from boundid._validation import as_float_array, as_matrix, as_vector
from boundid.errors import InputError, SolverError
from boundid.sets._plane import closed, plane, require_2d


def _hull(V: np.ndarray) -> ConvexHull:
    try:
        return ConvexHull(V)
    except QhullError:
        raise InputError(f"the {len(V)} points are flat (they span less than R^{V.shape[1]}): a polytope with an "
                         "empty interior has no facet description here; drop a coordinate or widen the set.") from None


class VertexPolytope:
    """The polytope conv(V) = {x : A x <= b}.

    Parameters
    ----------
    vertices : (n, p) array
        Points whose convex hull is the polytope (parameter units). Without ``facets`` only the
        hull's vertices are kept; with ``facets`` they are taken as the vertex list as given.
    facets : optional (A (k, p), b (k,))
        The facet inequalities A x <= b (unit-norm rows) when the caller has them (the
        recursive polytope keeps both descriptions); computed by Qhull otherwise.
    """

    __slots__ = ("vertices", "A", "b")

    def __init__(self, vertices, facets=None):
        V = as_matrix(vertices, "vertices")
        p = V.shape[1]
        if facets is not None:
            A, b = facets
            A = as_matrix(A, "facets A", ncols=p)
            b = as_vector(b, "facets b", A.shape[0])
        elif p == 1:
            V = np.array([[V.min()], [V.max()]])
            A, b = np.array([[1.0], [-1.0]]), np.array([V[1, 0], -V[0, 0]])
        else:
            hull = _hull(V)
            V = V[hull.vertices]
            eq = np.unique(np.round(hull.equations, 12), axis=0)   # coplanar triangles share a facet
            A, b = eq[:, :p], -eq[:, p]
        self.vertices, self.A, self.b = V.copy(), A.copy(), b.copy()

    @property
    def dim(self) -> int:
        return self.vertices.shape[1]

    def intervals(self) -> tuple[np.ndarray, np.ndarray]:
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def support(self, direction) -> float:
        """max over the vertices of d^T v."""
        d = as_vector(direction, "direction", self.dim)
        return float(np.max(self.vertices @ d))

    def supports(self, directions) -> np.ndarray:
        """max over the vertices of d^T v for each row d of ``directions`` (m, p)."""
        D = as_matrix(directions, "directions", self.dim)
        return np.max(D @ self.vertices.T, axis=1)

    def contains(self, points, rtol: float = 1e-9) -> np.ndarray | bool:
        """A x <= b + rtol * (the polytope's largest width), plus the rounding of the
        coordinates themselves (8 eps (|A| |x| + |b|)), for each point."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        lo, hi = self.intervals()
        ulp = 8 * np.finfo(float).eps * (np.abs(X) @ np.abs(self.A).T + np.abs(self.b))
        ok = np.all(X @ self.A.T <= self.b + rtol * float(np.max(hi - lo)) + ulp, axis=1)
        return bool(ok[0]) if np.ndim(points) == 1 else ok

    def gauge(self, points) -> np.ndarray | float:
        """NaN for each point (a polytope has no centre of its own to measure from; use :meth:`contains`)."""
        X = np.atleast_2d(as_float_array(points, "points"))
        return float("nan") if np.ndim(points) == 1 else np.full(X.shape[0], np.nan)

    def log_volume(self) -> float:
        """ln of the volume (Qhull); -inf for a flat polytope."""
        if self.dim == 1:
            with np.errstate(divide="ignore"):
                return float(np.log(np.ptp(self.vertices)))
        try:
            return float(np.log(ConvexHull(self.vertices).volume))
        except QhullError:
            return -np.inf

    def project(self, i: int, j: int) -> VertexPolytope:
        """The exact shadow on the plane (i, j): the polygon hull of the projected vertices."""
        return VertexPolytope(self.vertices[:, plane(i, j, self.dim)])

    def boundary(self, n_points: int = 200) -> np.ndarray:
        """The vertices of a polygon, counter-clockwise, closed."""
        require_2d(self.dim, "polytope")
        return closed(self.vertices[_hull(self.vertices).vertices])  # Qhull lists 2-D hulls counter-clockwise

    def __repr__(self) -> str:
        return f"VertexPolytope(dim={self.dim}, vertices={len(self.vertices)}, facets={len(self.b)})"


#: the shadow checks a direction against the normal cones of this many latest LP answers
_CONES = 8
#: d is in a basis's normal cone when its multipliers are >= -_CONE_TOL max |multiplier|
_CONE_TOL = 1e-10


def _cone_multipliers(N: np.ndarray, d: np.ndarray) -> np.ndarray | None:
    """lam with N^T lam = d (None if N is singular)."""
    try:
        return np.linalg.solve(N.T, d)
    except np.linalg.LinAlgError:
        return None


def shadow(polytope, i: int, j: int, rtol: float = 1e-9, max_lps: int = 10_000) -> VertexPolytope:
    """The exact shadow of a polytope on the plane of coordinates (i, j), as a polygon.

    ``polytope`` needs ``dim`` and ``support_point(d) -> (max d^T x, a maximiser x)`` (one LP for
    :class:`boundid.sets.Polytope`). Edge refinement: start from the support points along +-e_i,
    +-e_j (in counter-clockwise order); for every edge (a, b) of the current polygon ask for the
    support point q along its outward normal n; if n^T q exceeds n^T a by more than rtol (in
    coordinates scaled by the shadow's width along each axis, where it spans 1 x 1) q is a new vertex
    between a and b, else (a, b) is an edge of the shadow.
    Every edge of the result is certified by one LP, so the polygon is exact (to LP accuracy);
    the cost is about two LPs per edge. With ``support_cone(d) -> (value, x, N)`` (the outward
    normals N of the optimal basis at x, :meth:`boundid.sets.Polytope.support_cone`), a direction
    in the normal cone of an earlier answer's basis (d = N^T lam, lam >= 0) is answered by that
    vertex without an LP: most edges are certified so.
    """
    idx = plane(i, j, polytope.dim)
    n_lps = 0
    cones: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=_CONES)  # (vertex, outward normals of its basis)
    with_cone = getattr(polytope, "support_cone", None)

    def point(d2: np.ndarray) -> np.ndarray:
        nonlocal n_lps
        d = np.zeros(polytope.dim)
        d[idx] = d2
        for x, N in reversed(cones):
            lam = _cone_multipliers(N, d)
            if lam is not None and np.all(lam >= -_CONE_TOL * np.max(np.abs(lam))):
                return x[idx]
        n_lps += 1
        if n_lps > max_lps:
            raise SolverError(f"shadow: no closed polygon after {max_lps} LPs (inaccurate support points?).")
        _, x, N = with_cone(d) if with_cone is not None else (*polytope.support_point(d), None)
        x = np.asarray(x, dtype=float)
        if N is not None:
            cones.append((x, N))
        return x[idx]

    ring = [point(np.array(d, float)) for d in ((1, 0), (0, 1), (-1, 0), (0, -1))]
    # the refinement runs in coordinates scaled by the shadow's width along each axis (parameters of
    # different units: a tolerance on the wider axis alone would leave the narrow one coarse)
    width = np.maximum(np.ptp(np.array(ring), axis=0), np.finfo(float).tiny)
    tol = rtol

    def distinct(a, b):
        return np.max(np.abs(a - b)) > tol

    V = [ring[0] / width]
    for q in ring[1:]:
        if distinct(q / width, V[-1]) and distinct(q / width, V[0]):
            V.append(q / width)
    k = 0
    while k < len(V):
        a, b = V[k], V[(k + 1) % len(V)]
        n = np.array([b[1] - a[1], a[0] - b[0]])  # outward normal of the counter-clockwise edge a -> b
        nn = np.linalg.norm(n)
        if nn > 0:
            q = point(n / nn / width) / width      # n^T (x / width) = (n / width)^T x
            if (n / nn) @ (q - a) > tol and distinct(q, a) and distinct(q, b):
                V.insert(k + 1, q)
                continue
        k += 1
    V = np.array(V) * width
    if len(V) < 3:
        raise InputError(f"the shadow on ({i}, {j}) is flat (a segment or a point): the polytope has no "
                         "interior in that plane.")
    return VertexPolytope(V)
