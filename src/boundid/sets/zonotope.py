"""Zonotopes Z = c ⊕ G B^m = {c + G xi : |xi|_inf <= 1} ([AlamoBravoCamacho2005]).

A zonotope is the Minkowski sum of m segments [-g_k, g_k] about a centre c: centrally symmetric,
closed under linear maps (so its shadow on a plane is a 2-D zonotope, a zonogon) and cheap to
bound along any direction (support function d^T c + |G^T d|_1). Membership is an LP; the volume
is a sum over the C(m, p) square submatrices of G (McMullen's formula), computed exactly when that
sum is small and reported as NaN otherwise.
"""

from __future__ import annotations

import itertools
from math import comb

import numpy as np
from scipy.optimize import linprog
from scipy.special import logsumexp

from boundid._validation import as_float_array, as_vector
from boundid.errors import InputError, SolverError
from boundid.sets._plane import closed, plane, require_2d

#: log_volume() sums |det| over at most this many p-subsets of generators (else NaN)
MAX_VOLUME_SUBSETS = 200_000


def _generators(G, p: int) -> np.ndarray:
    G = as_float_array(G, "generators")
    if G.ndim == 1 and p == 1:
        G = G.reshape(1, -1)
    if G.ndim != 2 or G.shape[0] != p:
        raise InputError(f"generators must be a (p, m) matrix with p = {p} rows (one column per generator), "
                         f"got shape {G.shape}.")
    if not np.all(np.isfinite(G)):
        raise InputError("generators contain NaN or infinite values.")
    return G


class Zonotope:
    """The zonotope {c + G xi : |xi|_inf <= 1}.

    Parameters
    ----------
    center : (p,) array
        Centre c (parameter units).
    generators : (p, m) array
        Generator matrix G, one generator g_k per column (parameter units); m >= 0.
    """

    __slots__ = ("center", "generators")

    def __init__(self, center, generators):
        self.center = as_vector(center, "center").copy()
        self.generators = np.array(_generators(generators, self.center.shape[0]), dtype=float)

    @property
    def dim(self) -> int:
        return self.center.shape[0]

    @property
    def n_generators(self) -> int:
        return self.generators.shape[1]

    def radii(self) -> np.ndarray:
        """Half-width of Z along every axis, sum_k |G_jk| (p,)."""
        return np.abs(self.generators).sum(axis=1)

    def intervals(self) -> tuple[np.ndarray, np.ndarray]:
        r = self.radii()
        return self.center - r, self.center + r

    def support(self, direction) -> float:
        """max over Z of d^T x = d^T c + |G^T d|_1."""
        d = as_vector(direction, "direction", self.dim)
        return float(d @ self.center + np.abs(self.generators.T @ d).sum())

    def contains(self, points, rtol: float = 1e-9) -> np.ndarray | bool:
        """Whether each point x lies in Z: is there xi with G xi = x - c and |xi|_inf <= 1 + rtol?
        One HiGHS LP per point, rows scaled by Z's half-width along each axis (so the equality
        tolerance, 1e-10, is relative to Z's own size)."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        r = self.radii()
        scale = np.where(r > 0, r, 1.0)
        G = self.generators / scale[:, None]
        flat = r <= 0
        tol_flat = 4 * np.finfo(float).eps * (np.abs(self.center) + 1.0)
        ok = np.empty(X.shape[0], dtype=bool)
        bound = 1.0 + rtol
        for n, x in enumerate(X):
            dx = x - self.center
            if np.any(np.abs(dx[flat]) > tol_flat[flat]):
                ok[n] = False
                continue
            if self.n_generators == 0:
                ok[n] = True
                continue
            res = linprog(np.zeros(self.n_generators), A_eq=G[~flat], b_eq=dx[~flat] / scale[~flat],
                          bounds=(-bound, bound), method="highs",
                          options={"primal_feasibility_tolerance": 1e-10, "presolve": False})
            if res.status not in (0, 2):
                raise SolverError(f"Zonotope.contains: HiGHS returned status {res.status} ({res.message}).")
            ok[n] = res.status == 0
        return bool(ok[0]) if np.ndim(points) == 1 else ok

    def log_volume(self) -> float:
        """ln vol(Z) = p ln 2 + ln sum over p-subsets S of generators of |det G_S| (McMullen's
        formula); -inf when G has rank < p, NaN when there are more than MAX_VOLUME_SUBSETS subsets."""
        G = self.generators[:, np.any(self.generators != 0, axis=0)]
        p, m = G.shape
        if m < p or np.linalg.matrix_rank(G) < p:
            return -np.inf
        if comb(m, p) > MAX_VOLUME_SUBSETS:
            return np.nan
        subsets = np.array(list(itertools.combinations(range(m), p)))
        logs = []
        for start in range(0, len(subsets), 20_000):
            sign, logdet = np.linalg.slogdet(np.moveaxis(G[:, subsets[start:start + 20_000]], 1, 0))
            logs.append(logdet[sign != 0])
        return float(p * np.log(2.0) + logsumexp(np.concatenate(logs)))

    def project(self, i: int, j: int) -> Zonotope:
        """The shadow on the plane (i, j): the zonotope of rows (i, j) of c and G (exact)."""
        idx = plane(i, j, self.dim)
        G = self.generators[idx]
        return Zonotope(self.center[idx], G[:, np.any(G != 0, axis=0)])

    def vertices(self) -> np.ndarray:
        """The vertices of a 2-D zonotope (a zonogon), counter-clockwise, not closed (k, 2)."""
        require_2d(self.dim, "zonotope")
        G = self.generators[:, np.any(self.generators != 0, axis=0)].copy()
        if G.shape[1] == 0:
            return self.center[None, :].copy()
        # every generator into the upper half-plane, sorted by angle in [0, pi): walking the
        # edges 2 g_k from the lowest point c - sum g_k, then -2 g_k, goes round counter-clockwise
        flip = (G[1] < 0) | ((G[1] == 0) & (G[0] < 0))
        G[:, flip] *= -1
        G = G[:, np.argsort(np.arctan2(G[1], G[0]), kind="stable")]
        steps = np.hstack([2 * G, -2 * G]).T
        V = self.center - G.sum(axis=1) + np.vstack([np.zeros(2), np.cumsum(steps[:-1], axis=0)])
        # drop vertices on a straight edge (parallel generators)
        prev, nxt = np.roll(V, 1, axis=0), np.roll(V, -1, axis=0)
        cross = (V[:, 0] - prev[:, 0]) * (nxt[:, 1] - V[:, 1]) - (V[:, 1] - prev[:, 1]) * (nxt[:, 0] - V[:, 0])
        scale = np.abs(G).sum() ** 2
        keep = np.abs(cross) > 1e-12 * scale
        return V[keep] if keep.sum() >= 2 else V[:2]

    def boundary(self, n_points: int = 200) -> np.ndarray:
        """The vertices of a 2-D zonotope, counter-clockwise, closed."""
        return closed(self.vertices())

    def reduced(self, max_generators: int) -> Zonotope:
        """An outer zonotope with at most ``max_generators`` (>= p) generators ([Combastel2003]):
        keep the max_generators - p largest generators (Euclidean norm), replace the others by
        the box diag(sum_k |g_k|) (p axis generators), which contains their sum."""
        return Zonotope(self.center, reduce_generators(self.generators, max_generators))

    def __repr__(self) -> str:
        return f"Zonotope(dim={self.dim}, generators={self.n_generators})"


def reduce_generators(G: np.ndarray, max_generators: int) -> np.ndarray:
    """[Combastel2003] order reduction of a generator matrix G (p, m) to at most ``max_generators``
    columns (see :meth:`Zonotope.reduced`); G itself when it is already small enough."""
    p, m = G.shape
    if not (isinstance(max_generators, int | np.integer) and max_generators >= p):
        raise InputError(f"max_generators must be an integer >= p = {p}, got {max_generators!r}.")
    if m <= max_generators:
        return G
    order = np.argsort(-np.linalg.norm(G, axis=0), kind="stable")
    keep, boxed = order[: max_generators - p], order[max_generators - p:]
    return np.hstack([G[:, keep], np.diag(np.abs(G[:, boxed]).sum(axis=1))])
