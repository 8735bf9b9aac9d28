"""The `ConvexSet` protocol: what every guaranteed or confidence set offers to the layers below.

Certification, validation, figures and tables use only these methods, so an estimator may return
an ellipsoid, a box, a zonotope, a parallelotope or a polytope and be compared with the others.

Shapes: ``p`` parameters; a point is (p,), a batch of points (m, p).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class ConvexSet(Protocol):
    """A compact convex set in R^p."""

    @property
    def dim(self) -> int:
        """p, the dimension of the space the set lives in."""

    def intervals(self) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi), each (p,): the set's projection on every axis (its interval hull)."""

    def support(self, direction) -> float:
        """h(d) = max over x in the set of d^T x, for d (p,)."""

    def contains(self, points, rtol: float = 1e-9):
        """Whether a point (p,) lies in the set (bool), or each of (m, p) points ((m,) bool).

        The test allows only for rounding: ``rtol`` relative to the set's own scale (its
        Mahalanobis^2, normalised coordinates, half-widths or bounds), plus the rounding of the
        coordinates themselves; a point the set excludes by more is outside."""

    def gauge(self, points):
        """A scale-free measure of where each point lies, <= 1 inside and > 1 outside: the
        family's own where it is cheap and exact (an ellipsoid's Mahalanobis^2
        (x - c)^T S^-1 (x - c), a box's or parallelotope's largest normalised coordinate), NaN
        where the family has none (zonotopes, polytopes). A float for a point (p,), (m,) for (m, p)."""

    def log_volume(self) -> float:
        """ln of the p-dimensional volume; -inf for a flat set, NaN where the family cannot say."""

    def project(self, i: int, j: int) -> ConvexSet:
        """The set's shadow on the plane of parameters (i, j): a 2-D set of the same family
        (a polytope's shadow is a polygon), exact."""

    def boundary(self, n_points: int = 200) -> np.ndarray:
        """For a 2-D set only: its boundary as a closed polygon (m, 2), counter-clockwise, for
        drawing (vertices for polyhedral sets, ``n_points`` samples for curved ones)."""


def support_values(S: ConvexSet, directions) -> np.ndarray:
    """h_S(d) for each row d of ``directions`` (m, p): (m,). Every family of boundid has a batched
    ``supports`` (one matrix product for the closed forms; for polytopes one LP per distinct
    maximising vertex); a set of your own that has only ``support`` is asked once per row."""
    batched = getattr(S, "supports", None)
    if batched is not None:
        return np.asarray(batched(directions), dtype=float)
    return np.array([S.support(d) for d in np.atleast_2d(np.asarray(directions, dtype=float))])
