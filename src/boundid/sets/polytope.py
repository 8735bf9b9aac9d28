"""The feasible parameter set of bounded-error data: a polytope of strips (REFERENCES §3).

P = {theta : |y_k - w_k^T theta| <= e_k for every row k}  (optionally  ∩ box ∩ {A theta <= b}).

Every exact quantity here is an LP solved by HiGHS (``highspy``) with constraint generation
(:mod:`boundid.sets._working_set`): a small working set of rows, the most violated rows of the
whole data added after each solve, warm re-solves. Internally each strip is normalised by its
bound, a_k = w_k / e_k, c_k = y_k / e_k, so that it reads c_k - 1 <= a_k^T theta <= c_k + 1.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError, cKDTree

from boundid._validation import as_bounds, as_float_array, as_matrix, as_regression, as_vector
from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.sets._working_set import Block, LPStatusError, WorkingSetLP

#: largest dimension for which vertices() and volume() enumerate vertices exactly
MAX_VERTEX_DIM = 6
#: relative margin for "a side of a strip is reached by P" (LP solutions are accurate to ~1e-10)
_TOUCH_TOL = 1e-8


@dataclass(frozen=True)
class Bounds:
    """Exact per-parameter bounds of a polytope (2p LPs).

    lo, hi : (p,) min and max of each theta_j over P.
    argmin, argmax : (p, p) row j is a vertex of P where theta_j attains lo_j (resp. hi_j).
    info : solver statistics (working-set rows, LP solves, time_s).
    """

    lo: np.ndarray
    hi: np.ndarray
    argmin: np.ndarray
    argmax: np.ndarray
    info: dict = field(default_factory=dict)

    @property
    def center(self) -> np.ndarray:
        return 0.5 * (self.lo + self.hi)

    @property
    def half_width(self) -> np.ndarray:
        return 0.5 * (self.hi - self.lo)

    def vertices(self) -> np.ndarray:
        """The 2p optimal vertices stacked, (2p, p) (points of P, for containment checks)."""
        return np.vstack([self.argmin, self.argmax])


@dataclass(frozen=True)
class Consistency:
    """Result of the consistency LP gamma* = min_theta max_k |y_k - w_k^T theta| / e_k.

    gamma : gamma* (P is empty iff gamma > 1; gamma is the smallest uniform inflation of all
        bounds that makes the data consistent).
    theta : (p,) a minimiser (the minimax / Chebyshev-norm estimate).
    violated : indices of the rows with |y_k - w_k^T theta| > e_k at ``theta``.
    active : indices of the rows at the level gamma* at ``theta`` (they decide gamma*).
    """

    gamma: float
    theta: np.ndarray
    violated: np.ndarray
    active: np.ndarray

    @property
    def empty(self) -> bool:
        return self.gamma > 1.0 + 1e-9

    def __float__(self) -> float:
        return float(self.gamma)


def _box(box, p: int) -> tuple[np.ndarray, np.ndarray] | None:
    if box is None:
        return None
    try:
        lo, hi = box
    except (TypeError, ValueError):
        raise InputError("box must be a pair (lo, hi) of length-p arrays (use +-inf for open sides).") from None
    lo = np.broadcast_to(as_float_array(lo, "box lo"), (p,)).astype(float)
    hi = np.broadcast_to(as_float_array(hi, "box hi"), (p,)).astype(float)
    if np.any(np.isnan(lo)) or np.any(np.isnan(hi)):
        raise InputError("box contains NaN; use -inf/+inf for an unbounded side.")
    if np.any(lo >= hi):
        raise InputError(f"box needs lo < hi for every parameter; violated at indices {np.flatnonzero(lo >= hi)}.")
    return lo, hi


def _halfspaces(hs, p: int) -> tuple[np.ndarray, np.ndarray] | None:
    if hs is None:
        return None
    try:
        A, b = hs
    except (TypeError, ValueError):
        raise InputError("halfspaces must be a pair (A, b) meaning A theta <= b.") from None
    A = as_matrix(A, "halfspaces A", ncols=p)
    b = as_vector(b, "halfspaces b", A.shape[0])
    if np.any(np.linalg.norm(A, axis=1) == 0):
        raise InputError("halfspaces A has an all-zero row; drop it (0 <= b is not a constraint on theta).")
    return A, b


class Polytope:
    """The feasible set P = {theta : |y_k - w_k^T theta| <= e_k} ∩ box ∩ {A theta <= b}.

    Parameters
    ----------
    W : (N, p) regression rows w_k.
    y : (N,) targets y_k.
    e_max : scalar or (N,) strictly positive error bounds e_k (same unit as y).
    box : optional (lo, hi), each (p,), a prior box lo <= theta <= hi (+-inf for an open side).
    halfspaces : optional (A, b), A (m, p), b (m,): prior halfspaces A theta <= b.
    """

    def __init__(self, W, y, e_max, box=None, halfspaces=None):
        W, y = as_regression(W, y)
        e = as_bounds(e_max, W.shape[0])
        p = W.shape[1]
        self.W, self.y, self.e_max = W, y, e
        self.box = _box(box, p)
        self.halfspaces = _halfspaces(halfspaces, p)
        # normalised strips c_k - 1 <= a_k^T theta <= c_k + 1
        self._A = W / e[:, None]
        self._c = y / e
        if self.halfspaces is not None:
            nrm = np.linalg.norm(self.halfspaces[0], axis=1)
            self._H = self.halfspaces[0] / nrm[:, None]
            self._h = self.halfspaces[1] / nrm
        else:
            self._H, self._h = np.zeros((0, p)), np.zeros(0)
        self._engine: WorkingSetLP | None = None
        self._bounds: Bounds | None = None
        self._consistency: Consistency | None = None
        self._vertices: np.ndarray | None = None
        self._seed_rows: np.ndarray | None = None

    @classmethod
    def from_strips(cls, W, y, e_max, box=None, halfspaces=None) -> Polytope:
        """P from |y_k - w_k^T theta| <= e_max_k (see the class docstring)."""
        return cls(W, y, e_max, box=box, halfspaces=halfspaces)

    # ------------------------------------------------------------------ basics
    @property
    def dim(self) -> int:
        return self.W.shape[1]

    @property
    def n_strips(self) -> int:
        return self.W.shape[0]

    def __repr__(self) -> str:
        extra = (", box" if self.box is not None else "") + (
            f", {len(self._h)} halfspaces" if len(self._h) else "")
        return f"Polytope(dim={self.dim}, strips={self.n_strips}{extra})"

    def contains(self, points, atol: float = 1e-9) -> np.ndarray | bool:
        """Whether each point (row of ``points``) satisfies every constraint up to ``atol``
        (relative to each bound: |y_k - w_k^T x| <= e_k (1 + atol))."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        ok = np.all(np.abs(X @ self._A.T - self._c) <= 1.0 + atol, axis=1)
        if self.box is not None:
            ok &= np.all((X >= self.box[0] - atol * (1 + np.abs(self.box[0])))
                         & (X <= self.box[1] + atol * (1 + np.abs(self.box[1]))), axis=1)
        if len(self._h):
            ok &= np.all(X @ self._H.T <= self._h + atol * (1 + np.abs(self._h)), axis=1)
        return bool(ok[0]) if np.ndim(points) == 1 else ok

    def as_ranged_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every constraint as lo_i <= a_i^T theta <= up_i.

        Returns (A (M, p), lo (M,), up (M,), strip (M,)): the N normalised strips first
        (a = w/e, bounds c -+ 1, ``strip`` = row index k), then the finite sides of the box
        (unit rows, ``strip`` = -1), then the halfspaces (unit-norm rows, lo = -inf, ``strip`` = -1).
        """
        p = self.dim
        A, lo, up, idx = [self._A], [self._c - 1.0], [self._c + 1.0], [np.arange(self.n_strips)]
        if self.box is not None:
            blo, bhi = self.box
            keep = np.isfinite(blo) | np.isfinite(bhi)
            A.append(np.eye(p)[keep])
            lo.append(blo[keep])
            up.append(bhi[keep])
            idx.append(np.full(int(keep.sum()), -1))
        if len(self._h):
            A.append(self._H)
            lo.append(np.full(len(self._h), -np.inf))
            up.append(self._h)
            idx.append(np.full(len(self._h), -1))
        return np.vstack(A), np.concatenate(lo), np.concatenate(up), np.concatenate(idx)

    # ------------------------------------------------------------------ LP machinery
    def _seed(self) -> np.ndarray:
        """Rows chosen by QR with column pivoting of A^T: the strips of a bounding parallelotope
        (rank(A) of them; if rank(A) = p the working set is bounded from the start, and in any
        case its recession cone equals that of P, so it is unbounded only if P is)."""
        if self._seed_rows is None:
            A = self._A
            N, p = A.shape
            sv = np.sqrt(np.clip(np.linalg.eigvalsh(A.T @ A)[::-1], 0.0, None))
            rank = int(np.sum(sv > max(N, p) * np.finfo(float).eps * sv[0]))
            # pivoted QR on a strided sample of rows first (O(p^2) rows instead of N); the full
            # QR only if the sample does not span the row space of A
            sample = np.unique(np.linspace(0, N - 1, min(N, 20 * p)).astype(int))
            for rows in (sample, np.arange(N)):
                R, piv = scipy.linalg.qr(A[rows].T, mode="r", pivoting=True)
                d = np.abs(np.diag(R))
                r = int(np.sum(d > max(N, p) * np.finfo(float).eps * d[0])) if d.size else 0
                if r >= rank:
                    break
            self._seed_rows = np.sort(rows[piv[:r]])
        return self._seed_rows

    def _col_bounds(self, extra: tuple[float, float] | None = None):
        p = self.dim
        lo = self.box[0].copy() if self.box is not None else np.full(p, -np.inf)
        hi = self.box[1].copy() if self.box is not None else np.full(p, np.inf)
        if extra is not None:
            lo, hi = np.append(lo, extra[0]), np.append(hi, extra[1])
        return lo, hi

    def _theta_blocks(self) -> list[Block]:
        return [Block(self._A, self._c - 1.0, self._c + 1.0),
                Block(self._H, np.full(len(self._h), -np.inf), self._h.copy())]

    def _new_theta_engine(self, seed_from: WorkingSetLP | None = None) -> WorkingSetLP:
        seed = [(0, self._seed()), (1, np.arange(len(self._h)))]
        if seed_from is not None:
            seed = [(b, np.flatnonzero(m)) for b, m in enumerate(seed_from.in_ws)]
        return WorkingSetLP(self._theta_blocks(), *self._col_bounds(), seed=seed)

    def _theta_engine(self) -> WorkingSetLP:
        if self._engine is None:
            self._engine = self._new_theta_engine()
        return self._engine

    def _minimize(self, engine: WorkingSetLP, cost: np.ndarray) -> tuple[np.ndarray, float]:
        """cost^T theta minimised over P, translating LP statuses into boundid errors."""
        try:
            return engine.minimize(cost)
        except LPStatusError as exc:
            if exc.status == "unbounded":
                raise self._unbounded_error() from None
            cons = self.consistency()
            if cons.empty or exc.status == "infeasible":
                raise self._infeasible_error(cons) from None
            raise self._unbounded_error() from None

    def _unbounded_error(self) -> InputError:
        rank = len(self._seed())
        return InputError(
            f"the feasible set is unbounded: W ({self.n_strips} x {self.dim}) has numerical rank {rank}"
            + (f" < {self.dim}" if rank < self.dim else "")
            + " and the prior box/halfspaces do not close it. Excite every parameter (more varied "
            "trajectories), drop unidentifiable parameters, or pass a finite box prior.")

    def _infeasible_error(self, cons: Consistency) -> InfeasibleDataError:
        if not np.isfinite(cons.gamma):
            return InfeasibleDataError(
                "the prior (box and/or halfspaces) is empty on its own; check its bounds.")
        if not cons.empty:
            return InfeasibleDataError(
                f"the feasible set is empty to solver accuracy: gamma* = {cons.gamma:.10g} is 1 within "
                f"rounding, so the data sit exactly at the edge of consistency ({len(cons.active)} rows "
                f"active, first: {cons.active[:10].tolist()}). Enlarge e_max slightly or remove outliers.")
        return InfeasibleDataError(
            f"the data contradict the error bounds: the feasible set is empty. The smallest uniform "
            f"inflation of the bounds that makes the data consistent is gamma* = {cons.gamma:.6g} (> 1). "
            f"At the minimax estimate {len(cons.violated)} of {self.n_strips} rows exceed their bound; "
            f"{len(cons.active)} rows are active at gamma* (first: {cons.active[:10].tolist()}). Enlarge "
            f"e_max (by at least a factor {cons.gamma:.4g}), or detect and remove outliers "
            f"(e.g. the rows above) before building the polytope.")

    # ------------------------------------------------------------------ consistency
    def consistency(self) -> Consistency:
        """gamma* = min_theta max_k |y_k - w_k^T theta| / e_k over the prior (one LP,
        REFERENCES §3); gamma = inf if the prior alone is empty. Never raises for bad data."""
        if self._consistency is not None:
            return self._consistency
        A, c = self._A, self._c
        N, p = A.shape
        blocks = [Block(A, c.copy(), np.full(N, np.inf), g=np.ones(N)),       # a theta + t >= c
                  Block(A, np.full(N, -np.inf), c.copy(), g=-np.ones(N)),     # a theta - t <= c
                  Block(self._H, np.full(len(self._h), -np.inf), self._h.copy())]
        seed = [(0, self._seed()), (1, self._seed()), (2, np.arange(len(self._h)))]
        eng = WorkingSetLP(blocks, *self._col_bounds((0.0, np.inf)), seed=seed)
        cost = np.zeros(p + 1)
        cost[p] = 1.0
        try:
            x, gamma = eng.minimize(cost)
        except LPStatusError:
            res = Consistency(np.inf, np.full(p, np.nan), np.arange(N), np.zeros(0, dtype=int))
        else:
            theta = x[:p]
            rho = np.abs(A @ theta - c)
            gamma = max(gamma, float(rho.max()))
            res = Consistency(gamma, theta, np.flatnonzero(rho > 1.0 + 1e-9),
                              np.flatnonzero(rho >= gamma - 1e-7 * max(gamma, 1.0)))
        self._consistency = res
        return res

    def is_empty(self) -> bool:
        """True iff the data contradict the bounds (gamma* > 1) or the prior is empty."""
        return self.consistency().empty

    # ------------------------------------------------------------------ bounds and extents
    def bounds(self) -> Bounds:
        """Exact min and max of every parameter over P (2p LPs, one warm HiGHS model).

        Raises InfeasibleDataError if P is empty, InputError if P is unbounded.
        """
        if self._bounds is not None:
            return self._bounds
        t0 = time.perf_counter()
        p = self.dim
        eng = self._theta_engine()
        lo, hi = np.empty(p), np.empty(p)
        amin, amax = np.empty((p, p)), np.empty((p, p))
        for j in range(p):
            cost = np.zeros(p)
            cost[j] = 1.0
            amin[j], lo[j] = self._minimize(eng, cost)
            amax[j], v = self._minimize(eng, -cost)
            hi[j] = -v
        info = {"working_rows": eng.n_rows, "lp_solves": eng.n_solves, "time_s": time.perf_counter() - t0}
        self._bounds = Bounds(lo, hi, amin, amax, info)
        return self._bounds

    def _direction(self, direction) -> np.ndarray:
        return as_vector(direction, "direction", self.dim)

    def support(self, direction) -> float:
        """max over P of d^T theta (one LP)."""
        d = self._direction(direction)
        return -self._minimize(self._theta_engine(), -d)[1]

    def support_point(self, direction) -> tuple[float, np.ndarray]:
        """(max over P of d^T theta, a maximising vertex) (one LP); for projections of P."""
        d = self._direction(direction)
        x, v = self._minimize(self._theta_engine(), -d)
        return -v, x

    def extent(self, direction) -> tuple[float, float]:
        """(min, max) of d^T theta over P (two LPs)."""
        d = self._direction(direction)
        eng = self._theta_engine()
        return self._minimize(eng, d)[1], -self._minimize(eng, -d)[1]

    def tightened(self, rows=None) -> Polytope:
        """The strips ``rows`` (default: all) each shrunk to the exact extent of P along w_k
        (2 LPs per strip, REFERENCES §3 "strip tightening"); prior box and halfspaces kept.

        The result contains P and, when ``rows`` includes every non-redundant strip, equals it.
        A strip on which P is flat keeps a width of 1e-12 e_k (bounds must stay positive).
        """
        rows = np.arange(self.n_strips) if rows is None else np.asarray(rows, dtype=int)
        if rows.ndim != 1 or rows.size == 0 or rows.min() < 0 or rows.max() >= self.n_strips:
            raise InputError(f"rows must be a non-empty list of strip indices in [0, {self.n_strips}).")
        eng = self._theta_engine()
        lo, hi = np.empty(rows.size), np.empty(rows.size)
        for i, k in enumerate(rows):
            a = self._A[k]
            lo[i] = self._minimize(eng, a)[1]
            hi[i] = -self._minimize(eng, -a)[1]
        lo = np.maximum(lo, self._c[rows] - 1.0)
        hi = np.minimum(hi, self._c[rows] + 1.0)
        e = self.e_max[rows]
        half = np.maximum(0.5 * (hi - lo), 1e-12) * e
        return Polytope(self.W[rows], 0.5 * (hi + lo) * e, half, box=self.box, halfspaces=self.halfspaces)

    # ------------------------------------------------------------------ centre, redundancy
    def chebyshev_center(self) -> tuple[np.ndarray, float]:
        """(x, r): the centre and radius of the largest Euclidean ball in P
        (max r s.t. |y_k - w_k^T x| + r |w_k| <= e_k, box and halfspace sides likewise)."""
        A, c = self._A, self._c
        N, p = A.shape
        nu = np.linalg.norm(A, axis=1)
        blocks = [Block(A, np.full(N, -np.inf), c + 1.0, g=nu),
                  Block(A, c - 1.0, np.full(N, np.inf), g=-nu),
                  Block(self._H, np.full(len(self._h), -np.inf), self._h.copy(), g=np.ones(len(self._h)))]
        seed = [(0, self._seed()), (1, self._seed()), (2, np.arange(len(self._h)))]
        if self.box is not None:
            blo, bhi = self.box
            blocks += [Block(np.eye(p), np.full(p, -np.inf), bhi.copy(), g=np.ones(p)),
                       Block(np.eye(p), blo.copy(), np.full(p, np.inf), g=-np.ones(p))]
            seed += [(3, np.flatnonzero(np.isfinite(bhi))), (4, np.flatnonzero(np.isfinite(blo)))]
        eng = WorkingSetLP(blocks, np.append(np.full(p, -np.inf), 0.0), np.full(p + 1, np.inf), seed=seed)
        cost = np.zeros(p + 1)
        cost[p] = -1.0
        x, _ = self._minimize(eng, cost)
        return x[:p], float(x[p])

    def nonredundant(self) -> np.ndarray:
        """Indices of the strips that have at least one non-redundant side (a side whose
        removal would enlarge P), sorted.

        Screening first: a side that the bounding box of P (``bounds()``) does not reach is
        redundant (P is inside the box). Each surviving side gets one LP: maximise its normal
        over P with that side relaxed; it is non-redundant iff the maximum passes the side.
        Redundant sides are removed as they are found (sequential elimination), so duplicated
        strips keep exactly one copy and P equals the intersection of the strips returned
        with the prior box and halfspaces.
        """
        b = self.bounds()
        cb, hb = b.center, b.half_width
        mid = self._A @ cb
        rad = np.abs(self._A) @ hb
        L, U = self._c - 1.0, self._c + 1.0
        up_cand = mid + rad > U - _TOUCH_TOL * (1.0 + np.abs(U))
        lo_cand = mid - rad < L + _TOUCH_TOL * (1.0 + np.abs(L))
        eng = self._new_theta_engine(seed_from=self._theta_engine())
        # screened-out sides are dropped from the pool for good (valid: see the docstring)
        blk = eng.blocks[0]
        blk.up[~up_cand] = np.inf
        blk.lo[~lo_cand] = -np.inf
        for k in np.flatnonzero(~up_cand | ~lo_cand):
            if eng.row_of[0][k] >= 0:
                eng.set_bounds(0, k, blk.lo[k], blk.up[k])
        keep = np.zeros(self.n_strips, dtype=bool)
        for k in np.flatnonzero(up_cand | lo_cand):
            a = self._A[k]
            for side in (1.0, -1.0):
                if (side > 0 and not up_cand[k]) or (side < 0 and not lo_cand[k]):
                    continue
                bound = U[k] if side > 0 else L[k]
                if side > 0:
                    eng.set_bounds(0, k, blk.lo[k], U[k] + 1.0)
                else:
                    eng.set_bounds(0, k, L[k] - 1.0, blk.up[k])
                v = -self._minimize(eng, -side * a)[1]          # max of side * a^T theta
                if v > side * bound + _TOUCH_TOL * (1.0 + abs(bound)):
                    keep[k] = True
                    eng.set_bounds(0, k, L[k] if side < 0 else blk.lo[k], U[k] if side > 0 else blk.up[k])
                elif side > 0:
                    eng.set_bounds(0, k, blk.lo[k], np.inf)
                else:
                    eng.set_bounds(0, k, -np.inf, blk.up[k])
        return np.flatnonzero(keep)

    # ------------------------------------------------------------------ vertices, volume
    def _scaled_halfspaces(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Non-screened constraints as H z <= h in box coordinates theta = cb + hb * z
        (unit-norm rows), with (cb, hb)."""
        b = self.bounds()
        cb, hb = b.center, b.half_width
        if np.any(hb <= 0):
            raise InputError(f"P is flat (zero width along parameters {np.flatnonzero(hb <= 0)}); "
                             "it has no interior, so no vertex enumeration or volume.")
        A, lo, up, _ = self.as_ranged_rows()
        mid, rad = A @ cb, np.abs(A) @ hb
        As = A * hb
        rows, rhs = [], []
        for sgn, bound in ((1.0, up), (-1.0, lo)):
            fin = np.isfinite(bound)
            reach = sgn * (mid - bound) + rad > -_TOUCH_TOL * (1.0 + np.abs(np.where(fin, bound, 0.0)))
            sel = fin & reach
            rows.append(sgn * As[sel])
            rhs.append(sgn * (bound[sel] - mid[sel]))
        # the bounding box itself (implied by P) keeps the intersection bounded and well posed
        H = np.vstack(rows + [np.eye(self.dim), -np.eye(self.dim)])
        h = np.concatenate(rhs + [np.ones(2 * self.dim)])
        nrm = np.linalg.norm(H, axis=1)
        return H / nrm[:, None], h / nrm, cb, hb

    def vertices(self) -> np.ndarray:
        """All vertices of P, (n_vertices, p), for p <= 6 (scipy HalfspaceIntersection with the
        Chebyshev centre of P, in box-scaled coordinates, as interior point)."""
        if self._vertices is not None:
            return self._vertices
        p = self.dim
        if p > MAX_VERTEX_DIM:
            raise InputError(f"vertices() enumerates vertices for p <= {MAX_VERTEX_DIM} only (p = {p}); "
                             "use bounds() or the SDP ellipsoids in higher dimension.")
        if p == 1:
            b = self.bounds()
            self._vertices = np.array([[b.lo[0]], [b.hi[0]]])
            return self._vertices
        H, h, cb, hb = self._scaled_halfspaces()
        z0, r = _chebyshev(H, h)
        if r <= 1e-9:
            raise InputError(f"P has an empty interior (Chebyshev radius {r:.3g} in box-scaled units); "
                             "its vertices cannot be enumerated by halfspace intersection.")
        try:
            hsi = HalfspaceIntersection(np.hstack([H, -h[:, None]]), z0)
            Z = hsi.intersections
            Z = Z[ConvexHull(Z).vertices]
            # degenerate vertices (more than p sides through one point) come out several times
            first = [min(c) for c in cKDTree(Z).query_ball_point(Z, r=1e-9)]
            Z = Z[np.unique(first)]
        except QhullError as exc:
            raise SolverError(f"Qhull failed to enumerate the vertices of P: {exc}") from None
        self._vertices = cb + hb * Z
        return self._vertices

    def volume(self) -> float:
        """Exact volume of P for p <= 6 (ConvexHull of the vertices), in parameter units^p."""
        V = self.vertices()
        if self.dim == 1:
            return float(V[1, 0] - V[0, 0])
        b = self.bounds()
        Z = (V - b.center) / b.half_width
        return float(ConvexHull(Z).volume * np.prod(b.half_width))


def _chebyshev(H: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, float]:
    """Chebyshev centre of {z : H z <= h} with unit-norm rows (one HiGHS LP)."""
    m, n = H.shape
    eng = WorkingSetLP([Block(H, np.full(m, -np.inf), h.copy(), g=np.ones(m))],
                       np.append(np.full(n, -np.inf), 0.0), np.full(n + 1, np.inf), seed=[(0, np.arange(m))])
    cost = np.zeros(n + 1)
    cost[n] = -1.0
    try:
        x, _ = eng.minimize(cost)
    except LPStatusError as exc:
        raise SolverError(f"Chebyshev-centre LP reported {exc.status}.") from None
    return x[:n], float(x[n])
