"""Zonotopes Z = c ⊕ G B^m = {c + G xi : |xi|_inf <= 1} ([AlamoBravoCamacho2005]).

A zonotope is the Minkowski sum of m segments [-g_k, g_k] about a centre c: centrally symmetric,
closed under linear maps (so its shadow on a plane is a 2-D zonotope, a zonogon) and cheap to
bound along any direction (support function d^T c + |G^T d|_1). Membership is tested along the
C(m, p - 1) facet normals (an LP when there are too many); the volume is a sum over the C(m, p)
square submatrices of G (McMullen's formula), computed exactly when that sum is small and
reported as NaN otherwise.
"""

from __future__ import annotations

import itertools
from math import comb

import numpy as np
from scipy.optimize import linprog
from scipy.special import logsumexp

from boundid._validation import as_float_array, as_matrix, as_vector
from boundid.errors import InputError, SolverError
from boundid.sets._plane import closed, plane, require_2d

#: log_volume() sums |det| over at most this many p-subsets of generators (else NaN)
MAX_VOLUME_SUBSETS = 200_000
#: contains() tests the facet normals of at most this many (p - 1)-subsets (else an LP)
MAX_FACET_SUBSETS = 50_000
#: one membership LP costs about as much as this many facet normals (measured at p = 9, m = 18:
#: 5 ms against 18 us per normal): contains() of fewer points than C(m, p - 1) / LP_COST_IN_NORMALS
#: solves LPs, unless the normals are known already
LP_COST_IN_NORMALS = 300


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

    __slots__ = ("center", "generators", "_normals")

    def __init__(self, center, generators):
        self.center = as_vector(center, "center").copy()
        self.generators = np.array(_generators(generators, self.center.shape[0]), dtype=float)
        self._normals = None

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

    def supports(self, directions) -> np.ndarray:
        """max over Z of d^T x for each row d of ``directions`` (m, p)."""
        D = as_matrix(directions, "directions", self.dim)
        return D @ self.center + np.abs(D @ self.generators).sum(axis=1)

    def contains(self, points, rtol: float = 1e-9) -> np.ndarray | bool:
        """Whether each point lies in Z, allowing rtol of Z's half-width along each direction
        tested and the rounding of the coordinates themselves, 8 eps (|x| + |c| + sum_k |g_k|)
        per axis (a point of Z is c + G xi).

        Exact test: x is in Z iff |n^T (x - c)| <= |G^T n|_1 along every facet normal n, the
        normals of the hyperplanes spanned by p - 1 generators (any direction gives a valid
        inequality, so rounding in the normals cannot exclude a point of Z). Used when G has
        full rank and at most MAX_FACET_SUBSETS subsets, and the normals are cheaper than one LP
        per point (LP_COST_IN_NORMALS) or known already; otherwise an LP per point
        (:meth:`_contains_lp`, the same test to rtol).
        """
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        D = self._facet_normals() if self._normals is not None or self._normals_cheap(X.shape[0]) else None
        if D is None:
            ok = self._contains_lp(X, rtol)
        else:
            h = np.abs(D @ self.generators).sum(axis=1)
            ulp = 8 * np.finfo(float).eps * (np.abs(X) + np.abs(self.center) + self.radii())
            ok = np.all(np.abs((X - self.center) @ D.T) <= h * (1 + rtol) + ulp @ np.abs(D).T, axis=1)
        return bool(ok[0]) if np.ndim(points) == 1 else ok

    def gauge(self, points) -> np.ndarray | float:
        """NaN for each point: a zonotope's gauge needs an LP per point (use :meth:`contains`)."""
        X = np.atleast_2d(as_float_array(points, "points"))
        return float("nan") if np.ndim(points) == 1 else np.full(X.shape[0], np.nan)

    def _normals_cheap(self, n_points: int) -> bool:
        """Whether the facet normals cost less than ``n_points`` membership LPs."""
        m = int(np.count_nonzero(np.any(self.generators != 0, axis=0)))
        return self.dim == 1 or comb(m, self.dim - 1) <= LP_COST_IN_NORMALS * n_points

    def _facet_normals(self) -> np.ndarray | None:
        """Unit normals (k, p) of the hyperplanes spanned by p - 1 of the (non-zero) generators,
        or None when G is rank deficient or there are more than MAX_FACET_SUBSETS of them."""
        if self._normals is None:
            G = self.generators[:, np.any(self.generators != 0, axis=0)]
            p, m = G.shape
            if p == 1:
                self._normals = np.ones((1, 1))
            elif m < p or comb(m, p - 1) > MAX_FACET_SUBSETS or np.linalg.matrix_rank(G) < p:
                self._normals = False
            else:
                subsets = np.array(list(itertools.combinations(range(m), p - 1)))
                self._normals = np.linalg.svd(G.T[subsets])[2][:, -1, :]
        return None if self._normals is False else self._normals

    def _contains_lp(self, X: np.ndarray, rtol: float) -> np.ndarray:
        """Membership by LP (when the facet normals are too many): t* <= 1 + rtol, where t* is the
        least |xi|_inf over G xi + delta = x - c with |delta_j| <= 8 eps (|x_j| + |c_j| +
        sum_k |G_jk|) (the rounding of the coordinates themselves: a point of Z is c + G xi).

        One HiGHS LP per point, written in the principal frame of G (G = U S V^T; row i divided
        by max(s_i, 1e-14 s_1)), so that its equality rows V^T xi = ... are orthonormal even for
        a nearly flat zonotope. An infeasible LP (x - c off the span of G) means outside. The
        solution is checked: an equality residual rho on those rows is absorbed exactly by
        xi + V rho, so the point is inside iff t* + |rho|_2 <= 1 + rtol; on the rows of the null
        space of G (s_i below the floor) the residual must be below 1e-9.
        """
        p, m = self.dim, self.n_generators
        if m == 0 or not np.any(self.generators):
            U, sv = np.eye(p), np.zeros(p)
        else:
            U, sv, _ = np.linalg.svd(self.generators, full_matrices=True)
            sv = np.concatenate([sv, np.zeros(p - sv.size)])
        floor = 1e-14 * max(sv[0], np.finfo(float).tiny)
        null = sv <= floor
        scale = 1.0 / np.maximum(sv, floor)
        F = scale[:, None] * U.T                                   # the frame: rows u_i / s_i
        FG = F @ self.generators
        # variables [xi (m), delta' (p) in [-1, 1], t]: min t, F G xi + F D delta' = F dx, |xi_k| <= t
        A_ub = np.block([[np.eye(m), np.zeros((m, p)), -np.ones((m, 1))],
                         [-np.eye(m), np.zeros((m, p)), -np.ones((m, 1))]])
        cost = np.zeros(m + p + 1)
        cost[-1] = 1.0
        bounds = [(None, None)] * m + [(-1.0, 1.0)] * p + [(0, None)]
        ok = np.empty(X.shape[0], dtype=bool)
        for n, x in enumerate(X):
            ulp = 8 * np.finfo(float).eps * (np.abs(x) + np.abs(self.center) + self.radii())
            A_eq = np.hstack([FG, F * ulp, np.zeros((p, 1))])
            b = F @ (x - self.center)
            res = linprog(cost, A_ub=A_ub, b_ub=np.zeros(2 * m), A_eq=A_eq, b_eq=b, bounds=bounds, method="highs",
                          options={"primal_feasibility_tolerance": 1e-10})
            if res.status == 2:
                ok[n] = False
                continue
            rho = A_eq @ res.x - b if res.status == 0 else np.full(p, np.inf)
            if not np.all(np.abs(rho[null]) <= 1e-9) or not np.all(np.isfinite(rho)):
                raise SolverError(f"Zonotope.contains: HiGHS could not decide membership (status {res.status}: "
                                  f"{res.message}).")
            ok[n] = res.x[-1] + np.linalg.norm(rho[~null]) <= 1.0 + rtol
        return ok

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
