"""The shadow of a polytope on a pair of coordinates, for 2-D pictures of a p-D feasible set."""

from __future__ import annotations

import numpy as np

from boundid.sets import Polytope


def shadow_points(P: Polytope, idx, n_directions: int = 48) -> np.ndarray:
    """Points (k, 2) whose convex hull is the projection of P on coordinates ``idx``.

    For each of ``n_directions`` directions d in the plane, one LP gives the vertex of P that
    maximises d^T theta_idx; the projected vertices are vertices of the shadow, so their hull is
    exact where it touches and misses at most the slivers between adjacent directions.
    """
    i, j = idx
    pts = []
    for a in np.linspace(0.0, 2.0 * np.pi, n_directions, endpoint=False):
        d = np.zeros(P.dim)
        d[i], d[j] = np.cos(a), np.sin(a)
        _, x = P.support_point(d)
        pts.append(x[[i, j]])
    return np.array(pts)
