"""The feasible parameter set of bounded-error data: a polytope of strips ([refs §LP]).

P = {theta : |y_k - w_k^T theta| <= e_k for every row k}  (optionally  ∩ box ∩ {A theta <= b}).

Every exact quantity here is an LP solved with constraint generation
(:mod:`boundid.sets._working_set`): a small working set of rows, the most violated rows of the
whole data added after each solve, warm re-solves (a dense vertex simplex, HiGHS when it gives up
and for every verdict of infeasibility).

Well-scaled coordinates (the *frame*). The LPs never see theta itself but z with
theta = origin + scale * z (element-wise), so that the answer does not depend on the units of
the parameters or of y:

* first frame: ``scale_j`` = 1 / RMS_k(w_kj / e_k) (column equilibration; capped by the prior
  box's half-width), ``origin`` = a least-squares fit on a sample of rows (so that the strips
  pass near z = 0 even when e_k is 1e-9 of |y_k|);
* during and after the bounds: the LP bounding box itself, origin = its centre and scale = its
  half-widths, so that P spans [-1, 1] along every z_j. bounds() runs in stages on strided
  samples of the rows (N / 16^k); after each stage it moves to the frame of that stage's
  bounding box (which contains P's) and drops the strips that contain the box (no later optimum
  can violate them: the box-screen); the last stage is re-solved once more in the
  final box frame when that frame was off by more than 10x in some direction and the vertices
  fail their certificate (see Bounds) where they were solved. The boxes only shrink, so each
  screen tests only the strips the previous box left.

A frame stores no array of size N: r_k and n_k below are computed (compiled, one read of the row)
for the rows a pass or the working set uses, so the passes over all N rows are three: the column
scales, the first box screen and the residuals of the certificate.

In z, strip k is {z : |r_k - (w_k * scale)^T z| <= e_k} with r_k = y_k - w_k^T origin; each row
is divided by n_k = |w_k * scale|, so the LP rows have unit norm, the strip's half-width is
e_k / n_k and every LP tolerance is a Euclidean distance in box units (1e-9 of P's half-widths).
The prior box becomes column bounds (lo - origin) / scale <= z <= (hi - origin) / scale and the
halfspaces A theta <= b become (A * scale) z <= b - A origin, normalised the same way.

Certificates. ``Consistency.theta`` is a point whose residuals are evaluated on the original
data (gamma is the largest |y_k - w_k^T theta| / e_k there); ``Bounds`` carries the 2p optimal
vertices and their mean, each checked against the original strips, box and halfspaces before
the bounds are returned (tolerances stated in :class:`Bounds`).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.linalg
import scipy.optimize
from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError, cKDTree

from boundid._validation import as_bounds, as_float_array, as_matrix, as_regression, as_vector
from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.sets._plane import require_2d
from boundid.sets._working_set import (
    CHUNK,
    Block,
    LPStatusError,
    StripBlock,
    WorkingSetLP,
    box_reach,
    col_rms,
    frame_rows,
    level_ratios,
    max_ratio,
    minimize_in_threads,
    reaches_in_threads,
    sample_levels,
    strided_sample,
)
from boundid.sets.vertex_polytope import VertexPolytope, shadow

#: largest dimension for which vertices() and volume() enumerate vertices exactly
MAX_VERTEX_DIM = 6
#: relative margin for "a side of a strip is reached by P" (LP solutions are accurate to ~1e-10)
TOUCH_TOL = 1e-8
#: LP feasibility tolerance of the pool rows, in frame units (a distance in z)
LP_TOL = 1e-9
#: stated tolerance of the vertex certificate, relative to P's half-widths (see Bounds)
VERTEX_TOL = 1e-8
#: threads that share a batch of strip extents (:meth:`Polytope._strip_reach`) and the LP bounds' 2p
#: objectives, each on its own copy of the working-set LP (the cores this process may use, at most 2);
#: a batch of fewer than _THREAD_MIN directions stays on one
LP_THREADS = min(2, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)
_THREAD_MIN = 16
#: the LP engine's working set is cut back (WorkingSetLP.prune: its seed, its last basis and the newest
#: remembered bases) when a call starts with more rows than _ROWS_PER_COL per parameter
_ROWS_PER_COL = 30


def _max_rows(p: int) -> int:
    return max(1000, _ROWS_PER_COL * p)


#: the bounds are re-solved in the box frame when a half-width in the first frame is outside this
_FRAME_OK = (0.1, 10.0)
_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class Bounds:
    """Exact per-parameter bounds of a polytope (2p LPs).

    lo, hi : (p,) min and max of each theta_j over P.
    argmin, argmax : (p, p) row j is a vertex of P where theta_j attains lo_j (resp. hi_j).
    info : solver statistics (working-set rows, LP solves, passes over the data, time_s, frame).
    point : (p,) the mean of the 2p vertices, a point of P (by convexity): the feasibility
        certificate, its residuals evaluated on the original data.
    residual_ratio : max_k |y_k - w_k^T point| / e_k at ``point`` (<= 1: ``point`` is in P).
    vertex_excess : the certificate of the vertices, checked before the bounds are returned:
        max over the 2p vertices x and every row k of (|y_k - w_k^T x| - e_k) / tau_k with
        tau_k = 1e-8 |w_k * half_width| + 16 eps (|y_k| + |w_k|^T |x|) (1e-8 of P's width
        along the strip, plus the rounding of the residual); <= 1 by construction (a larger
        value raises SolverError). Box sides and halfspaces are checked likewise.
    """

    lo: np.ndarray
    hi: np.ndarray
    argmin: np.ndarray
    argmax: np.ndarray
    info: dict = field(default_factory=dict)
    point: np.ndarray | None = None
    residual_ratio: float = float("nan")
    vertex_excess: float = float("nan")

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

    gamma : max_k |y_k - w_k^T theta| / e_k evaluated on the original data at ``theta`` (an
        upper bound on gamma*, equal to it to solver accuracy; P is empty iff gamma* > 1; gamma
        is the smallest uniform inflation of all bounds that makes the data consistent).
    theta : (p,) a minimiser (the minimax / Chebyshev-norm estimate): when gamma <= 1 it is a
        point of P, the feasibility certificate.
    violated : indices of the rows with |y_k - w_k^T theta| > e_k at ``theta``.
    active : indices of the rows at the level gamma* at ``theta`` (they decide gamma*).
    lp_gamma : the LP's optimal value (solved in well-scaled coordinates).
    tol : resolution of the verdict: 1e-9 plus the rounding of the residuals in double
        precision, 16 eps max_k (|y_k| + |w_k|^T |theta|) / e_k (relevant when e_k << |y_k|).
    """

    gamma: float
    theta: np.ndarray
    violated: np.ndarray
    active: np.ndarray
    lp_gamma: float = float("nan")
    tol: float = 1e-9

    @property
    def empty(self) -> bool:
        """True iff both the LP value and the value at ``theta`` exceed 1 + tol."""
        lp = self.lp_gamma if np.isfinite(self.lp_gamma) or np.isinf(self.gamma) else self.gamma
        return min(self.gamma, lp) > 1.0 + self.tol

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


def _chunks(n: int):
    for start in range(0, n, CHUNK):
        yield slice(start, min(n, start + CHUNK))


class _Frame:
    """Well-scaled coordinates theta = origin + scale * z and the strips seen from them:
    r = y - W origin, n = |w_k * scale| (1 for an all-zero row), computed for the rows asked
    (``rn``, :func:`frame_rows`) or, on the paths that need every row, once in full (``r``, ``n``).
    A change of frame costs nothing until a row is used."""

    def __init__(self, origin: np.ndarray, scale: np.ndarray, W: np.ndarray, y: np.ndarray):
        self.origin, self.scale = np.array(origin, dtype=float), np.array(scale, dtype=float)
        self._W, self._y = W, y

    def rn(self, rows) -> tuple[np.ndarray, np.ndarray]:
        """(r, n) of the strips ``rows`` (index array or slice)."""
        return frame_rows(np.ascontiguousarray(self._W[rows]), self._y[rows], self.origin, self.scale)

    @cached_property
    def _full(self) -> tuple[np.ndarray, np.ndarray]:
        return frame_rows(self._W, self._y, self.origin, self.scale)

    @property
    def r(self) -> np.ndarray:
        return self._full[0]

    @property
    def n(self) -> np.ndarray:
        return self._full[1]

    def to_theta(self, Z: np.ndarray) -> np.ndarray:
        return self.origin + self.scale * Z


class Polytope:
    """The feasible set P = {theta : |y_k - w_k^T theta| <= e_k} ∩ box ∩ {A theta <= b}.

    Parameters
    ----------
    W : (N, p) regression rows w_k (referenced, not copied, if already float64).
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
        self._frame: _Frame | None = None
        self._first: _Frame | None = None
        self._engine: WorkingSetLP | None = None
        #: (engine, its clones for the other LP threads), made when a batch is first shared
        self._clones: tuple[WorkingSetLP | None, list[WorkingSetLP]] = (None, [])
        self._bounds: Bounds | None = None
        self._consistency: Consistency | None = None
        self._vertices: np.ndarray | None = None
        self._rank: int | None = None
        #: points of P found by LPs (theta units), for screening and for verifying outer sets
        self._found: list[np.ndarray] = []
        #: results of the SDPs of boundid.sets.sdp on this P (they are deterministic)
        self._sdp_cache: dict = {}

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
            f", {len(self.halfspaces[1])} halfspaces" if self.halfspaces is not None else "")
        return f"Polytope(dim={self.dim}, strips={self.n_strips}{extra})"

    def residual_ratio(self, points) -> np.ndarray:
        """max_k |y_k - w_k^T x| / e_k for each row x of ``points`` (m, p), on the original data."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        return max_ratio(self.W, self.y, self.e_max, np.ascontiguousarray(X, dtype=float))

    def contains(self, points, rtol: float = 1e-9) -> np.ndarray | bool:
        """Whether each point (row of ``points``) satisfies every constraint up to ``rtol``
        (relative to each bound: |y_k - w_k^T x| <= e_k (1 + rtol); box sides and halfspaces
        within rtol (1 + |bound|))."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        ok = self.residual_ratio(X) <= 1.0 + rtol
        if self.box is not None:
            ok &= np.all((X >= self.box[0] - rtol * (1 + np.abs(self.box[0])))
                         & (X <= self.box[1] + rtol * (1 + np.abs(self.box[1]))), axis=1)
        if self.halfspaces is not None:
            H, h = self.halfspaces
            nrm = np.linalg.norm(H, axis=1)
            ok &= np.all(X @ (H / nrm[:, None]).T <= h / nrm + rtol * (1 + np.abs(h / nrm)), axis=1)
        return bool(ok[0]) if np.ndim(points) == 1 else ok

    def gauge(self, points) -> np.ndarray | float:
        """NaN for each point (P has no centre of its own to measure from; :meth:`residual_ratio`
        tells how far a point is from satisfying every strip)."""
        X = np.atleast_2d(as_float_array(points, "points"))
        return float("nan") if np.ndim(points) == 1 else np.full(X.shape[0], np.nan)

    def as_ranged_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every constraint as lo_i <= a_i^T theta <= up_i.

        Returns (A (M, p), lo (M,), up (M,), strip (M,)): the N normalised strips first
        (a = w/e, bounds y/e -+ 1, ``strip`` = row index k), then the finite sides of the box
        (unit rows, ``strip`` = -1), then the halfspaces (unit-norm rows, lo = -inf, ``strip`` = -1).
        """
        p = self.dim
        c = self.y / self.e_max
        A, lo, up, idx = [self.W / self.e_max[:, None]], [c - 1.0], [c + 1.0], [np.arange(self.n_strips)]
        if self.box is not None:
            blo, bhi = self.box
            keep = np.isfinite(blo) | np.isfinite(bhi)
            A.append(np.eye(p)[keep])
            lo.append(blo[keep])
            up.append(bhi[keep])
            idx.append(np.full(int(keep.sum()), -1))
        if self.halfspaces is not None:
            H, h = self.halfspaces
            nrm = np.linalg.norm(H, axis=1)
            A.append(H / nrm[:, None])
            lo.append(np.full(len(h), -np.inf))
            up.append(h / nrm)
            idx.append(np.full(len(h), -1))
        return np.vstack(A), np.concatenate(lo), np.concatenate(up), np.concatenate(idx)

    # ------------------------------------------------------------------ the frame
    def _make_frame(self, origin: np.ndarray, scale: np.ndarray) -> _Frame:
        return _Frame(origin, scale, self.W, self.y)

    def _first_frame(self) -> _Frame:
        """Column equilibration (capped by the box) and a least-squares origin (module docstring)."""
        W, y, e = self.W, self.y, self.e_max
        N, p = W.shape
        rms = col_rms(W, e)
        scale = np.where(rms > 0, 1.0 / np.where(rms > 0, rms, 1.0), np.inf)
        if self.box is not None:
            hb = 0.5 * (self.box[1] - self.box[0])
            scale = np.where(np.isfinite(hb), np.minimum(scale, hb), scale)
        scale[~np.isfinite(scale)] = 1.0          # a column the data never see and no box closes
        rows = np.unique(np.linspace(0, N - 1, min(N, 50 * p)).astype(np.int64))
        As = W[rows] * scale / e[rows, None]
        origin = np.zeros(p)
        for _ in range(2):                        # least squares, then one step of refinement
            res = (y[rows] - W[rows] @ origin) / e[rows]
            origin = origin + scale * np.linalg.lstsq(As, res, rcond=None)[0]
        if self.box is not None:
            lo, hi = self.box
            origin = np.clip(origin, np.where(np.isfinite(lo), lo, -np.inf), np.where(np.isfinite(hi), hi, np.inf))
            with np.errstate(invalid="ignore"):  # -inf + inf on a side open both ways: NaN, not used
                mid = 0.5 * (lo + hi)
            origin = np.where(np.isfinite(mid), np.where(origin <= lo, mid, origin), origin)
            origin = np.where(np.isfinite(mid), np.where(origin >= hi, mid, origin), origin)
        return self._make_frame(origin, scale)

    def _get_frame(self) -> _Frame:
        """The current frame (the first until :meth:`bounds` moves to P's bounding box)."""
        if self._frame is None:
            self._frame = self._frame0()
        return self._frame

    def _frame0(self) -> _Frame:
        """The first frame, computed once: the consistency LP and the rank run in it whatever frame
        the bounds moved to (the bounding box of a P that is one point is no frame to solve in)."""
        if self._first is None:
            self._first = self._first_frame()
        return self._first

    def _strip_block(self, F: _Frame) -> Block:
        """The strips in frame F: (r_k - e_k)/n_k <= (w_k * scale)^T z / n_k <= (r_k + e_k)/n_k,
        as arrays of every row (bounds that can be changed one by one)."""
        return Block(self.W, (F.r - self.e_max) / F.n, (F.r + self.e_max) / F.n, d=F.scale, s=F.n)

    def _strip_pool(self, F: _Frame) -> StripBlock:
        """The same strips, each row computed when a pass or the working set uses it."""
        return StripBlock(self.W, self.y, self.e_max, F.origin, F.scale)

    def _halfspace_block(self, F: _Frame, g_extra=None) -> Block:
        if self.halfspaces is None:
            return Block(np.zeros((0, self.dim)), np.zeros(0), np.zeros(0), d=F.scale, s=np.ones(0),
                         g=None if g_extra is None else np.zeros(0))
        H, h = self.halfspaces
        s = np.linalg.norm(H * F.scale, axis=1)
        g = None if g_extra is None else g_extra(H, s)
        return Block(H, np.full(len(h), -np.inf), (h - H @ F.origin) / s, d=F.scale, s=s, g=g)

    def _col_bounds(self, F: _Frame, extra: tuple[float, float] | None = None):
        p = self.dim
        lo = (self.box[0] - F.origin) / F.scale if self.box is not None else np.full(p, -np.inf)
        hi = (self.box[1] - F.origin) / F.scale if self.box is not None else np.full(p, np.inf)
        if extra is not None:
            lo, hi = np.append(lo, extra[0]), np.append(hi, extra[1])
        return lo, hi

    def _seed(self, F: _Frame) -> np.ndarray:
        """Rows chosen by QR with column pivoting of the frame's unit rows on a strided sample
        (rank of the data many of them; if the rank is p the working set is bounded from the
        start). Rows are added for directions the sample does not see but the data do."""
        W, N, p = self.W, self.n_strips, self.dim
        rows = np.unique(np.linspace(0, N - 1, min(N, 20 * p)).astype(np.int64))
        for _ in range(p + 1):
            A = W[rows] * F.scale / F.rn(rows)[1][:, None]
            R, piv = scipy.linalg.qr(A.T, mode="r", pivoting=True)
            d = np.abs(np.diag(R))
            r = int(np.sum(d > max(N, p) * _EPS * d[0])) if d.size and d[0] > 0 else 0
            if r == p or r >= self._data_rank(F):
                break
            _, _, Vt = np.linalg.svd(A, full_matrices=True)
            null = Vt[r:]                          # directions the sample does not see
            best, arg = np.zeros(null.shape[0]), np.zeros(null.shape[0], dtype=np.int64)
            for sl in _chunks(N):
                proj = np.abs((W[sl] * F.scale / F.rn(sl)[1][:, None]) @ null.T)
                i = np.argmax(proj, axis=0)
                better = proj[i, np.arange(len(i))] > best
                best[better], arg[better] = proj[i, np.arange(len(i))][better], sl.start + i[better]
            rows = np.union1d(rows, arg[best > 0])
        return np.sort(rows[piv[:r]])

    def _data_rank(self, F: _Frame) -> int:
        """Numerical rank of the frame's unit rows (one pass for their Gram matrix G = A^T A). G's
        eigenvalues carry rounding of about eps |G| = eps sigma_1^2, so a singular value below
        sqrt(eps) sigma_1 is out of its reach: the rank counts eigenvalues above max(N, p) eps
        lambda_1 (a threshold on sigma^2 where the QR of :meth:`_seed` puts its own on sigma; on
        sigma itself, rounding counted absent directions: 45 for a rank-33 block of 3,000 rows)."""
        if self._rank is None:
            G = np.zeros((self.dim, self.dim))
            for sl in _chunks(self.n_strips):
                A = self.W[sl] * F.scale / F.rn(sl)[1][:, None]
                G += A.T @ A
            ev = np.linalg.eigvalsh(G)[::-1]
            self._rank = int(np.sum(ev > max(self.n_strips, self.dim) * _EPS * ev[0])) if ev[0] > 0 else 0
        return self._rank

    def _theta_engine(self) -> WorkingSetLP:
        if self._engine is None:
            F = self._get_frame()
            self._engine = WorkingSetLP([self._strip_pool(F), self._halfspace_block(F)], *self._col_bounds(F),
                                        seed=[(0, self._seed(F)), (1, np.arange(self._n_half))], tol=LP_TOL,
                                        max_rows=_max_rows(self.dim))
        return self._engine

    @property
    def _n_half(self) -> int:
        return 0 if self.halfspaces is None else len(self.halfspaces[1])

    def _box_reach(self, F: _Frame, rows: np.ndarray | None = None) -> np.ndarray:
        """Strips not implied by the box [-1, 1]^p of frame F (|g_k|_1 reaches a side, with a
        relative margin TOUCH_TOL): the strips of ``rows`` (None: all, one pass) that P can
        touch if P lies in that box."""
        sel = np.zeros(0, dtype=np.int64) if rows is None else np.asarray(rows, dtype=np.int64)
        keep = box_reach(self.W, self.y, self.e_max, sel, F.origin, F.scale, 1.0, TOUCH_TOL)
        return np.flatnonzero(keep) if rows is None else sel[keep]

    def _set_frame(self, F: _Frame, pool: np.ndarray | None = None) -> None:
        """Move the LPs to frame F, keeping the working set's rows; ``pool``: the strips the
        passes look at (None: all)."""
        old = self._engine
        self._frame = F
        self._clones = (None, [])                  # the old engine's copies go with it
        seed = [(0, old.ws_rows(0)), (1, np.arange(self._n_half))] if old is not None else \
            [(0, self._seed(F)), (1, np.arange(self._n_half))]
        self._engine = WorkingSetLP([self._strip_pool(F), self._halfspace_block(F)], *self._col_bounds(F),
                                    seed=seed, tol=LP_TOL, max_rows=_max_rows(self.dim),
                                    keep=old.keep_rows() if old is not None else None)
        if old is not None:
            self._engine.take_basis(old)
        self._engine.active[0] = pool

    # ------------------------------------------------------------------ LP calls
    def _minimize_many(self, costs_z: np.ndarray, levels: tuple[int, ...] = (), threads: bool = False) -> np.ndarray:
        """argmin over P of each row of ``costs_z`` (k, p) in frame coordinates -> (k, p) in z; ``threads``:
        the objectives shared by LP_THREADS threads, each on its own copy of the working-set LP."""
        eng = self._theta_engine()
        try:
            if threads and not levels and LP_THREADS > 1 and len(costs_z) >= 2 * LP_THREADS:
                return minimize_in_threads([eng, *self._engine_clones(LP_THREADS - 1)], costs_z)
            return eng.minimize_many(costs_z, levels=levels)
        except LPStatusError as exc:
            raise self._status_error(exc.status) from None

    def _status_error(self, status: str) -> Exception:
        if status == "unbounded":
            return self._unbounded_error()
        cons = self.consistency()
        if cons.empty:
            return self._infeasible_error(cons)
        if status == "infeasible":
            if cons.gamma >= 1.0 - 1e-6:
                return self._infeasible_error(cons)
            return SolverError(
                f"HiGHS reported the feasible set empty although the point theta = {cons.theta.tolist()} "
                f"satisfies every strip (max |y - w^T theta| / e = {cons.gamma:.6g} < 1): a numerical "
                "failure. Check the data for rows of very different magnitude, or report the case.")
        return self._unbounded_error()

    def _unbounded_error(self) -> InputError:
        rank = self._data_rank(self._frame0())
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
                f"the feasible set is empty to solver accuracy: gamma* = 1 + {cons.gamma - 1:.2g} is 1 within "
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
        [refs §LP]); gamma = inf if the prior alone is empty. Never raises for bad data.

        Solved in the first frame: rows [w_k * scale, e_k] / |[w_k * scale, e_k]| on (z, t), so
        that both the parameters and the level t = gamma are well scaled; at large N in stages
        on strided samples, with the strips that no optimum can reach screened out by a box
        (see :meth:`_level_screen`)."""
        if self._consistency is not None:
            return self._consistency
        F = self._frame0()
        W, e = self.W, self.e_max
        N, p = W.shape
        blocks = [StripBlock(W, self.y, e, F.origin, F.scale, side=+1),      # w z + e t >= r
                  StripBlock(W, self.y, e, F.origin, F.scale, side=-1),      # w z - e t <= r
                  self._halfspace_block(F, g_extra=lambda H, sh: np.zeros(len(sh)))]
        seed = self._seed(F)
        eng = WorkingSetLP(blocks, *self._col_bounds(F, (0.0, np.inf)),
                           seed=[(0, seed), (1, seed), (2, np.arange(self._n_half))], tol=LP_TOL)
        cost = np.zeros(p + 1)
        cost[p] = 1.0
        levels = sample_levels(N)
        pool = None                                  # strips some optimum can reach (None: all)
        try:
            for stage in [*levels, None]:
                rows = pool if stage is None else strided_sample(N, stage)
                if stage is not None and pool is not None:
                    rows = np.intersect1d(rows, pool, assume_unique=True)
                eng.active[0] = eng.active[1] = rows
                x = eng.minimize_many(cost[None, :])[0]
                if stage is not None and pool is None:
                    pool = self._level_screen(eng, F, x, rows)
        except LPStatusError:
            res = Consistency(np.inf, np.full(p, np.nan), np.arange(N), np.zeros(0, dtype=int), np.inf)
        else:
            theta = F.to_theta(x[:p])
            rho, mag = level_ratios(W, self.y, e, F.origin, F.scale * x[:p], theta)
            gamma = float(rho.max())
            tol = 1e-9 + 16 * _EPS * mag
            res = Consistency(gamma, theta, np.flatnonzero(rho > 1.0 + tol),
                              np.flatnonzero(rho >= gamma - 1e-7 * max(gamma, 1.0)), float(x[p]), tol)
        self._consistency = res
        return res

    def _level_screen(self, eng: WorkingSetLP, F: _Frame, x: np.ndarray, rows: np.ndarray) -> np.ndarray | None:
        """The strips that the consistency LP can still need, after its stage on the sample
        ``rows`` ended at (z, t) = x; the LP ``eng`` gets the box that proves it (column bounds).

        t_lo = t is a lower bound on gamma* (the sample is a relaxation) and t_up, the largest
        residual ratio at z over every strip (one pass), an upper bound. Every optimal z* lies in
        {z : |r_k - w_k z| <= e_k t_up for the sample's strips}, whose bounding box (2p LPs on
        the sample) therefore holds z*: adding it as column bounds keeps gamma*, and then every
        later LP point has z in that box and t >= t_lo, so a strip with max over the box of
        |r_k - w_k z| below e_k t_lo (one pass, margin TOUCH_TOL) is never violated. None when
        that box is not bounded (the sample does not close P) or adds nothing."""
        p = self.dim
        t_lo = float(x[p])
        t_up = float(max_ratio(self.W, self.y, self.e_max, F.to_theta(x[:p])[None, :])[0]) * (1 + 1e-6)
        box = WorkingSetLP([StripBlock(self.W, self.y, self.e_max, F.origin, F.scale, level=t_up),
                            self._halfspace_block(F)], *self._col_bounds(F),
                           seed=[(0, np.union1d(eng.ws_rows(0), eng.ws_rows(1))), (1, np.arange(self._n_half))],
                           tol=LP_TOL)
        box.active[0] = rows
        try:
            Z = box.minimize_many(np.vstack([np.eye(p), -np.eye(p)]))
        except LPStatusError:
            return None
        zlo, zhi = np.diag(Z[:p]), np.diag(Z[p:])
        pad = 1e-6 * (zhi - zlo) + 1e-6                 # far above the LP tolerance (1e-9)
        zlo, zhi = zlo - pad, zhi + pad
        eng.set_col_bounds(np.append(np.maximum(zlo, eng.col_lo[:p]), eng.col_lo[p:]),
                           np.append(np.minimum(zhi, eng.col_hi[:p]), eng.col_hi[p:]))
        keep = box_reach(self.W, self.y, self.e_max, np.zeros(0, dtype=np.int64), F.to_theta(0.5 * (zlo + zhi)),
                         F.scale * 0.5 * (zhi - zlo), t_lo, TOUCH_TOL)
        return np.flatnonzero(keep)

    def is_empty(self) -> bool:
        """True iff the data contradict the bounds (gamma* > 1) or the prior is empty."""
        return self.consistency().empty

    # ------------------------------------------------------------------ bounds and extents
    def bounds(self) -> Bounds:
        """Exact min and max of every parameter over P (2p LPs on one warm working set).

        Raises InfeasibleDataError if P is empty, InputError if P is unbounded, SolverError if
        the vertices fail their certificate (see :class:`Bounds`).
        """
        if self._bounds is not None:
            return self._bounds
        t0 = time.perf_counter()
        p = self.dim
        costs = np.vstack([np.eye(p), -np.eye(p)])
        stats = {"lp_solves": 0, "passes": 0, "frames": 0}
        # P = -P (y = 0, a box symmetric about 0, no halfspaces: e.g. an excitation's design set): in a
        # frame centred at 0 the maximiser of each coordinate is minus its minimiser, so p LPs do
        centred = self.halfspaces is None and not np.any(self.y) and \
            (self.box is None or np.array_equal(self.box[0], -self.box[1]))

        def axes_optima() -> np.ndarray:
            if centred and not np.any(self._frame.origin):        # (the engine, hence the frame, exists)
                Z = self._minimize_many(costs[:p], threads=True)
                return np.vstack([Z, -Z])
            return self._minimize_many(costs, threads=True)

        def count():
            engines = [self._engine, *(self._clones[1] if self._clones[0] is self._engine else [])]
            stats["lp_solves"] += sum(e.n_solves for e in engines)
            stats["passes"] += sum(e.n_passes for e in engines)
            stats["frames"] += 1

        # stages on strided samples; after each, move to the frame of its bounding box (which
        # contains P's): the next stage and the last one then run where P spans about [-1, 1]
        levels = sample_levels(self.n_strips)
        resolved = False
        reach = None                                   # strips the current box can leave
        for stage in [*levels, None]:
            rows = reach if stage is None else strided_sample(self.n_strips, stage)
            if stage is not None and reach is not None:
                rows = np.intersect1d(rows, reach, assume_unique=True)
            self._theta_engine().active[0] = rows
            Z = axes_optima()
            F = self._frame
            zlo, zhi = np.diag(Z[:p]), np.diag(Z[p:])
            hw, cz = 0.5 * (zhi - zlo), 0.5 * (zhi + zlo)
            if hw.max() <= 0:
                break
            box_frame = self._make_frame(F.to_theta(cz), F.scale * np.maximum(hw, 1e-12 * hw.max()))
            lo_ok, hi_ok = _FRAME_OK
            off = np.any(hw < lo_ok) or np.any(hw > hi_ok) or np.any(np.abs(cz) > hi_ok * np.maximum(hw, 1.0))
            count()
            if stage is None and off and not self._certified(F.to_theta(Z), F.scale * hw, rows):
                self._set_frame(box_frame, reach)      # re-solve where P spans [-1, 1]
                Z = axes_optima()
                F = self._frame
                resolved = True
                count()
            Zt = F.to_theta(Z)
            # every later optimum lies in the working set's polytope, inside this stage's
            # bounding box ([-1, 1]^p in box_frame): a strip containing that box is never violated.
            # The boxes only shrink, so only the strips that reached the last one are tested again
            reach = self._box_reach(box_frame, reach)
            self._set_frame(box_frame, reach)
            Z = (Zt - box_frame.origin) / box_frame.scale
            F = box_frame
        stats["working_rows"] = self._engine.n_rows
        stats["strips_reaching_box"] = int(reach.size) if reach is not None else self.n_strips
        X = F.to_theta(Z)
        if self.box is not None:
            # the LP keeps the box as its column bounds; only the way back from the frame (origin +
            # scale z, through every stage's frame) can leave X outside it, by rounding: a P that is
            # one point, at a box corner, was refused by the certificate below for 11 ulps of theta
            X = np.clip(X, self.box[0], self.box[1])
        amin, amax = X[:p], X[p:]
        lo, hi = np.diag(amin).copy(), np.diag(amax).copy()
        self._found.extend(X)
        point = X.mean(axis=0)
        excess = self._vertex_excess(X, 0.5 * (hi - lo), reach)
        ratio = float(self.residual_ratio(point)[0])
        info = {**stats, "time_s": time.perf_counter() - t0, "resolved_in_box_frame": resolved}
        self._bounds = Bounds(lo, hi, amin, amax, info, point, ratio, excess)
        return self._bounds

    def _certified(self, X: np.ndarray, half_width: np.ndarray, rows: np.ndarray | None) -> bool:
        """Whether the points X pass the vertex certificate of Bounds (see _vertex_excess)."""
        try:
            self._vertex_excess(X, half_width, rows)
        except SolverError:
            return False
        return True

    def _vertex_excess(self, X: np.ndarray, half_width: np.ndarray, rows: np.ndarray | None = None) -> float:
        """max over points X (m, p) and constraints of violation / stated tolerance (see Bounds);
        raises SolverError above 1. ``rows``: the strips that can be violated at all (the others
        contain the bounding box of P, which holds X, with a margin; None: every strip)."""
        worst, where = 0.0, ""
        idx = np.arange(self.n_strips) if rows is None else rows
        for sl in _chunks(idx.size):
            sl = idx[sl]
            Ws = self.W[sl]
            R = np.abs(self.y[sl, None] - Ws @ X.T) - self.e_max[sl, None]
            rows, cols = np.nonzero(R > 0)                # only rows outside their bound need tau
            if rows.size == 0:
                continue
            Wr, Xc = Ws[rows], X[cols]
            tau = VERTEX_TOL * np.linalg.norm(Wr * half_width, axis=1) \
                + 16 * _EPS * (np.abs(self.y[sl][rows]) + np.einsum("ij,ij->i", np.abs(Wr), np.abs(Xc)))
            q = R[rows, cols] / np.maximum(tau, np.finfo(float).tiny)
            if q.max() > worst:
                worst, where = float(q.max()), f"strip {int(sl[rows[np.argmax(q)]])}"
        if self.box is not None:
            tau = VERTEX_TOL * half_width + 16 * _EPS * np.abs(X)
            q = np.maximum(self.box[0] - X, X - self.box[1]) / np.maximum(tau, np.finfo(float).tiny)
            if q.max() > worst:
                worst, where = float(q.max()), "prior box"
        if self.halfspaces is not None:
            H, h = self.halfspaces
            tau = VERTEX_TOL * np.linalg.norm(H * half_width, axis=1)[:, None] \
                + 16 * _EPS * (np.abs(h)[:, None] + np.abs(H) @ np.abs(X).T)
            q = (H @ X.T - h[:, None]) / np.maximum(tau, np.finfo(float).tiny)
            if q.max() > worst:
                worst, where = float(q.max()), "halfspace"
        if worst > 1.0:
            raise SolverError(
                f"the LP vertices fail their certificate: one violates the {where} by {worst:.3g} times "
                f"the stated tolerance (1e-8 of P's width along the constraint plus rounding). The data "
                "may have rows of wildly different magnitude; rescale them, or report the case.")
        return worst

    def _cost_z(self, direction: np.ndarray) -> tuple[np.ndarray, float, float]:
        """A direction d of theta space in frame coordinates: d^T theta = off + nrm * (u^T z)."""
        F = self._theta_frame()
        dz = direction * F.scale
        nrm = float(np.linalg.norm(dz))
        if nrm == 0:
            raise InputError("direction must not be zero.")
        return dz / nrm, float(direction @ F.origin), nrm

    def _theta_frame(self) -> _Frame:
        self._theta_engine()
        return self._frame

    def _direction(self, direction) -> np.ndarray:
        return as_vector(direction, "direction", self.dim)

    def support_point(self, direction) -> tuple[float, np.ndarray]:
        """(max over P of d^T theta, a maximising vertex) (one LP); for projections of P."""
        return self.support_cone(direction)[:2]

    def support_cone(self, direction) -> tuple[float, np.ndarray, np.ndarray | None]:
        """:meth:`support_point` and the outward normals N (p, p) (theta space) of the constraints
        of P active in the LP's optimal basis: the vertex maximises every d = N^T lam with lam >= 0
        too (KKT), so a caller may answer such directions without an LP. N is None when the answer
        has no basis of p constraints."""
        d = self._direction(direction)
        u, off, nrm = self._cost_z(d)
        z = self._minimize_many(-u[None, :])[0]
        F = self._frame
        x = F.to_theta(z)
        self._found.append(x)
        found = self._engine.active_normals(z)
        return off + nrm * float(u @ z), x, None if found is None else found[0] / F.scale[None, :]

    def support_points(self, directions) -> tuple[np.ndarray, np.ndarray]:
        """(max over P of d^T theta, a maximising vertex) for each row d of ``directions`` (m, p):
        values (m,), points (m, p). Batched: one LP per distinct optimal basis, every other
        direction in that basis's normal cone answered by the same vertex (no LP); from _THREAD_MIN
        directions on, the first and second halves in LP_THREADS threads."""
        D = as_matrix(directions, "directions", self.dim)
        if np.any(~np.any(D != 0, axis=1)):
            raise InputError("directions must not contain a zero row.")
        F = self._theta_frame()
        Dz = D * F.scale
        nrm = np.linalg.norm(Dz, axis=1)
        eng = self._engine
        try:
            if LP_THREADS > 1 and len(D) >= _THREAD_MIN:
                vals, V, which, _ = reaches_in_threads([eng, *self._engine_clones(LP_THREADS - 1)], Dz / nrm[:, None],
                                                       np.inf)
            else:
                vals, V, which = eng.supports(Dz / nrm[:, None])
        except LPStatusError as exc:
            raise self._status_error(exc.status) from None
        X = F.to_theta(V)
        self._found.extend(X)
        return D @ F.origin + nrm * vals, X[which]

    def support(self, direction) -> float:
        """max over P of d^T theta (one LP)."""
        return self.support_point(direction)[0]

    def supports(self, directions) -> np.ndarray:
        """max over P of d^T theta for each row d of ``directions`` (m, p) (:meth:`support_points`)."""
        return self.support_points(directions)[0]

    def intervals(self) -> tuple[np.ndarray, np.ndarray]:
        """The exact parameter bounds (lo, hi) of :meth:`bounds` (2p LPs, cached)."""
        b = self.bounds()
        return b.lo.copy(), b.hi.copy()

    def project(self, i: int, j: int, rtol: float = 1e-9) -> VertexPolytope:
        """The exact shadow of P on the plane (i, j), a polygon (support-point LPs,
        :func:`boundid.sets.vertex_polytope.shadow`): its vertices are vertices of the shadow, and, in
        axes scaled by the shadow's width along each, the shadow reaches at most ``rtol`` beyond any of
        its edges."""
        return shadow(self, i, j, rtol=rtol)

    def boundary(self, n_points: int = 200) -> np.ndarray:
        """For p = 2: P's vertices, counter-clockwise, closed."""
        require_2d(self.dim, "polytope")
        return VertexPolytope(self.vertices()).boundary()

    def extent(self, direction) -> tuple[float, float]:
        """(min, max) of d^T theta over P (two LPs)."""
        d = self._direction(direction)
        return -self.support(-d), self.support(d)

    def _strip_extents(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) of (w_k * scale)^T z / n_k over P in the current frame for strips ``rows``: both
        sides exactly, by :meth:`_strip_reach` (normal cones shared)."""
        rows = np.asarray(rows, dtype=np.int64)
        up = np.concatenate([np.ones(rows.size, dtype=bool), np.zeros(rows.size, dtype=bool)])
        vals, _ = self._strip_reach(np.concatenate([rows, rows]), up, np.where(up, np.inf, -np.inf))
        return vals[rows.size:], vals[: rows.size]

    def _strip_reach(self, rows: np.ndarray, upper: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One side of each strip of ``rows`` (k,) over P, in the current frame along its unit normal
        g_k = (w_k * scale) / n_k: max of g_k^T z where ``upper`` (k,) is True, else min; or, where a
        point of P reaches ``targets`` (k,; for an upper side a value >= it, for a lower side <= it;
        +inf on an upper side and -inf on a lower one ask for the extent), the value of such a point.
        Returns (values (k,), exact (k,) True where the value is the extent)."""
        self.bounds()
        eng = self._engine
        F = self._frame
        rows = np.asarray(rows, dtype=np.int64)
        r, n = F.rn(rows)
        sgn = np.where(upper, 1.0, -1.0)
        D = sgn[:, None] * self.W[rows] * F.scale / n[:, None]
        side = (sgn * r + self.e_max[rows]) / n        # the strip's own side, along D
        goal = sgn * np.asarray(targets, dtype=float)
        # a side that a known point of P touches is the extent itself, one beyond the target settles it: no LP
        Zk = (self.found_points() - F.origin) / F.scale
        best = np.max(D @ Zk.T, axis=1) if len(Zk) else np.full(rows.size, -np.inf)
        touched = best >= side - LP_TOL
        vals = np.where(touched, side, np.where(best >= goal, best, np.nan))
        exact = touched.copy()
        todo = np.isnan(vals)
        if todo.any():
            try:
                if LP_THREADS > 1 and todo.sum() >= _THREAD_MIN:
                    v, V, _, ex = reaches_in_threads([eng, *self._engine_clones(LP_THREADS - 1)], D[todo], goal[todo])
                else:
                    v, V, _, ex = eng.reaches(D[todo], goal[todo])
            except LPStatusError as exc:
                raise self._status_error(exc.status) from None
            vals[todo], exact[todo] = v, ex
            self._found.extend(F.to_theta(V))
        return sgn * vals, exact

    def _engine_clones(self, k: int) -> list[WorkingSetLP]:
        """k copies of the LP engine for other threads (:meth:`WorkingSetLP.clone`), made once per engine."""
        if self._clones[0] is not self._engine or len(self._clones[1]) != k:
            self._clones = (self._engine, [self._engine.clone() for _ in range(k)])
        return self._clones[1]

    def tightened(self, rows=None) -> Polytope:
        """The strips ``rows`` (default: all) each shrunk to the exact extent of P along w_k
        ([refs §LP] "strip tightening"; supports batched by normal cones, so far fewer than
        2 LPs per strip); prior box and halfspaces kept.

        The result contains P (each tightened strip is widened by the LP tolerance, 1e-9 of P's
        half-widths along w_k, so that no vertex of P is left outside by solver rounding) and,
        when ``rows`` includes every non-redundant strip, equals it up to that tolerance.
        A strip on which P is flat keeps a width of 1e-12 e_k (bounds must stay positive).
        """
        rows = np.arange(self.n_strips) if rows is None else np.asarray(rows, dtype=int)
        if rows.ndim != 1 or rows.size == 0 or rows.min() < 0 or rows.max() >= self.n_strips:
            raise InputError(f"rows must be a non-empty list of strip indices in [0, {self.n_strips}).")
        lz, uz = self._strip_extents(rows)
        r, n = self._frame.rn(rows)
        # w^T theta = w^T origin + n * (unit row)^T z; as residual bounds on r = y - w^T theta
        r_hi = r - n * (lz - LP_TOL)              # residual at the low end of w^T theta
        r_lo = r - n * (uz + LP_TOL)
        e = self.e_max[rows]
        r_lo, r_hi = np.maximum(r_lo, -e), np.minimum(r_hi, e)
        half = np.maximum(0.5 * (r_hi - r_lo), 1e-12 * e)
        y_new = self.y[rows] - 0.5 * (r_hi + r_lo)
        return Polytope(self.W[rows], y_new, half, box=self.box, halfspaces=self.halfspaces)

    # ------------------------------------------------------------------ centre, redundancy
    def chebyshev_center(self) -> tuple[np.ndarray, float]:
        """(x, r): the centre and radius of the largest Euclidean ball in P
        (max r s.t. |y_k - w_k^T x| + r |w_k| <= e_k, box and halfspace sides likewise).

        Solved in the frame with the radius in units of the smallest frame scale."""
        F = self._theta_frame()
        W, e = self.W, self.e_max
        N, p = W.shape
        rs = float(F.scale.min())
        wn = np.linalg.norm(W, axis=1) * rs / F.n
        lo_s, up_s = (F.r - e) / F.n, (F.r + e) / F.n
        blocks = [Block(W, np.full(N, -np.inf), up_s, g=wn, d=F.scale, s=F.n),
                  Block(W, lo_s, np.full(N, np.inf), g=-wn, d=F.scale, s=F.n),
                  self._halfspace_block(F, g_extra=lambda H, sh: np.linalg.norm(H, axis=1) * rs / sh)]
        seed_rows = self._engine.ws_rows(0) if self._engine is not None else self._seed(F)
        seed = [(0, seed_rows), (1, seed_rows), (2, np.arange(self._n_half))]
        if self.box is not None:
            zlo, zhi = self._col_bounds(F)
            I = np.eye(p)
            blocks += [Block(I, np.full(p, -np.inf), zhi, g=rs / F.scale),
                       Block(I, zlo, np.full(p, np.inf), g=-rs / F.scale)]
            seed += [(3, np.flatnonzero(np.isfinite(zhi))), (4, np.flatnonzero(np.isfinite(zlo)))]
        eng = WorkingSetLP(blocks, np.append(np.full(p, -np.inf), 0.0), np.full(p + 1, np.inf), seed=seed,
                           tol=LP_TOL)
        cost = np.zeros(p + 1)
        cost[p] = -1.0
        try:
            x = eng.minimize_many(cost[None, :])[0]
        except LPStatusError as exc:
            raise self._status_error(exc.status) from None
        return F.to_theta(x[:p]), float(x[p]) * rs

    def nonredundant(self) -> np.ndarray:
        """Indices of the strips that have at least one non-redundant side (a side whose
        removal would enlarge P by more than 1e-8 (1 + |bound|) along its normal, in box units),
        sorted; P equals the intersection of the strips returned with the prior box and
        halfspaces, and duplicated strips keep exactly one copy (the last).

        Output-sensitive, in the box frame (P spans [-1, 1]^p), sequential elimination in which
        each side is decided by a certificate when one is at hand and by an LP otherwise:

        1. box screen: a side that the bounding box of P does not reach contains P;
        2. the supports of P along the remaining sides, batched by normal cones (one LP per
           distinct optimal vertex, :meth:`WorkingSetLP.supports`): a side that P does not
           touch is redundant; a side that it touches is active at the vertex v found;
        3. at v, the side k is redundant iff its normal g_k lies in the cone of the normals of
           the other sides active at v (LP duality: complementary slackness puts the multipliers
           of max g_k^T z over P without k on those sides). Non-negative least squares gives the
           multipliers (Farkas certificate: g_k = sum lambda_j g_j, sum lambda_j b_j <= b_k + tol)
           or a residual u with g_j^T u <= 0 for every active j: the ray v + t u then leaves P
           through side k alone, and a point on it beyond k by more than tol that satisfies
           every other side is the certificate of non-redundancy [Clarkson1994];
        4. a side with neither certificate gets one LP with that side relaxed (the textbook test).

        LPs: one per distinct vertex of step 2 plus one per undecided side, instead of one per
        side the bounding box reaches.
        """
        self.bounds()
        F = self._frame
        reach = self._engine.active[0]
        cand = self._box_reach(F, None) if reach is None else np.asarray(reach, dtype=np.int64)
        G, b, opp, strip = self._candidate_sides(F, cand)
        Hp, hp = self._prior_rows(F)
        tol = TOUCH_TOL * (1.0 + np.abs(b))
        live = np.ones(len(b), dtype=bool)
        keep = np.zeros(len(b), dtype=bool)
        if len(b):
            box = np.full(self.dim, 1.0 + 1e-6)              # P lies in [-1, 1]^p (to LP accuracy)
            try:
                vals, V, which = self._engine.supports(G, below=b - tol, outer=(-box, box))
            except LPStatusError as exc:
                raise self._status_error(exc.status) from None
            self._found.extend(F.to_theta(V))
            live &= (which >= 0) & (vals >= b - tol)
            todo = []
            for v in np.unique(which[live]):
                ks = np.flatnonzero(live & (which == v))
                todo += _vertex_certificates(ks, V[v], G, b, Hp, hp, tol, live, keep)
            keep[todo] = self._relaxed_lps(G, b, Hp, hp, tol, live, keep, np.asarray(todo, dtype=np.int64))
        return np.unique(strip[keep])

    def _candidate_sides(self, F: _Frame, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The sides of strips ``rows`` that reach the box [-1, 1]^p of frame F, as unit rows
        g^T z <= b, ordered by strip, upper side first: (G (m, p), b (m,), opp (m,), strip
        index (m,)), opp the bound of -g^T z from the same strip's other side."""
        r, n = F.rn(rows)
        A = self.W[rows] * F.scale / n[:, None]
        up, lo = (r + self.e_max[rows]) / n, (r - self.e_max[rows]) / n
        reach = np.abs(A).sum(axis=1)
        nonzero = np.any(A != 0, axis=1)
        u = nonzero & (reach > up - TOUCH_TOL * (1.0 + np.abs(up)))
        lw = nonzero & (-reach < lo + TOUCH_TOL * (1.0 + np.abs(lo)))
        G = np.stack([A, -A], axis=1).reshape(-1, A.shape[1])
        b = np.stack([up, -lo], axis=1).ravel()
        opp = np.stack([-lo, up], axis=1).ravel()
        sel = np.stack([u, lw], axis=1).ravel()
        return G[sel], b[sel], opp[sel], np.repeat(rows, 2)[sel]

    def _prior_rows(self, F: _Frame) -> tuple[np.ndarray, np.ndarray]:
        """The prior box sides and halfspaces in frame F as unit rows H z <= h."""
        p = self.dim
        rows, rhs = [np.zeros((0, p))], [np.zeros(0)]
        zlo, zhi = self._col_bounds(F)
        I = np.eye(p)
        rows += [I[np.isfinite(zhi)], -I[np.isfinite(zlo)]]
        rhs += [zhi[np.isfinite(zhi)], -zlo[np.isfinite(zlo)]]
        if self.halfspaces is not None:
            H, h = self.halfspaces
            Hz = H * F.scale
            nrm = np.linalg.norm(Hz, axis=1)
            rows.append(Hz / nrm[:, None])
            rhs.append((h - H @ F.origin) / nrm)
        return np.vstack(rows), np.concatenate(rhs)

    def _relaxed_lps(self, G, b, Hp, hp, tol, live, keep, todo) -> np.ndarray:
        """Step 4 of :meth:`nonredundant`: for each side h of ``todo`` in turn, max g_h^T z over
        the other live sides and the prior with side h relaxed by 1 (one LP); h is kept if the
        maximum exceeds b_h + tol_h, else it leaves ``live`` (sequential elimination). Returns a
        boolean mask over ``todo``."""
        out = np.zeros(todo.size, dtype=bool)
        if todo.size == 0:
            return out
        n_side, p = len(b), G.shape[1]
        eng = WorkingSetLP([Block(G, np.full(n_side, -np.inf), np.where(live, b, np.inf)),
                            Block(Hp, np.full(len(hp), -np.inf), hp)], np.full(p, -np.inf), np.full(p, np.inf),
                           seed=[(0, np.flatnonzero(keep)), (1, np.arange(len(hp)))], tol=LP_TOL)
        for i, h in enumerate(todo):
            eng.set_bounds(0, h, -np.inf, b[h] + 1.0)
            eng.add_rows(0, np.array([h]))              # bounds the objective from the start
            try:
                x = eng.minimize_many(-G[h][None, :])[0]
            except LPStatusError as exc:
                raise self._status_error(exc.status) from None
            out[i] = float(G[h] @ x) > b[h] + tol[h]
            eng.set_bounds(0, h, -np.inf, b[h] if out[i] else np.inf)
            live[h] = out[i]
        return out

    # ------------------------------------------------------------------ vertices, volume
    def _scaled_halfspaces(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Constraints the bounding box reaches as H z <= h in box coordinates
        theta = cb + hb * z (unit-norm rows), with (cb, hb)."""
        b = self.bounds()
        cb, hb = b.center, b.half_width
        if np.any(hb <= 0):
            raise InputError(f"P is flat (zero width along parameters {np.flatnonzero(hb <= 0)}); "
                             "it has no interior, so no vertex enumeration or volume.")
        G, c, h = self._unit_strips(cb, hb)
        reach = np.abs(G).sum(axis=1)
        rows, rhs = [], []
        for sgn in (1.0, -1.0):
            bound = sgn * c + h                     # sgn g^T z <= sgn c + h
            sel = reach > bound - TOUCH_TOL * (1.0 + np.abs(bound))
            rows.append(sgn * G[sel])
            rhs.append(bound[sel])
        p = self.dim
        if self.box is not None:
            zlo, zhi = (self.box[0] - cb) / hb, (self.box[1] - cb) / hb
            for sgn, bound in ((1.0, zhi), (-1.0, -zlo)):
                sel = np.isfinite(bound) & (bound < 1.0 + TOUCH_TOL)
                rows.append(sgn * np.eye(p)[sel])
                rhs.append(bound[sel])
        if self.halfspaces is not None:
            H, hv = self.halfspaces
            Hs = H * hb
            rows.append(Hs)
            rhs.append(hv - H @ cb)
        # the bounding box itself (implied by P) keeps the intersection bounded and well posed
        H = np.vstack(rows + [np.eye(p), -np.eye(p)])
        h = np.concatenate(rhs + [np.ones(2 * p)])
        nrm = np.linalg.norm(H, axis=1)
        return H / nrm[:, None], h / nrm, cb, hb

    def _unit_strips(self, cb: np.ndarray, hb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every strip as |g_k^T z - c_k| <= h_k in coordinates theta = cb + hb * z, unit-norm g_k:
        (G (N, p), c (N,), h (N,)); an all-zero row gets g = 0 and h = inf."""
        F = self._frame
        if F is None or not (np.array_equal(F.origin, cb) and np.array_equal(F.scale, hb)):
            F = self._make_frame(cb, hb)
        return self._frame_strips(F)

    def _frame_strips(self, F: _Frame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The strips in frame F as |g_k^T z - c_k| <= h_k, unit-norm g_k (one N x p copy)."""
        G = self.W * F.scale / F.n[:, None]
        zero = ~np.any(G != 0, axis=1)
        return G, F.r / F.n, np.where(zero, np.inf, self.e_max / F.n)

    def box_frame(self) -> tuple[np.ndarray, np.ndarray]:
        """(origin, scale) of the coordinates theta = origin + scale * z in which the LPs run
        after ``bounds()``: P spans [-1, 1] along every z_j (to the rounding of the bounds)."""
        self.bounds()
        return self._frame.origin.copy(), self._frame.scale.copy()

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

    def log_volume(self) -> float:
        """ln of :meth:`volume` for p <= MAX_VERTEX_DIM (exact, by the vertices), NaN beyond (the
        protocol's "cannot say": the volume of an H-polytope is #P-hard in general)."""
        if self.dim > MAX_VERTEX_DIM:
            return float("nan")
        return float(np.log(self.volume()))

    def volume(self) -> float:
        """Exact volume of P for p <= 6 (ConvexHull of the vertices), in parameter units^p."""
        V = self.vertices()
        if self.dim == 1:
            return float(V[1, 0] - V[0, 0])
        b = self.bounds()
        Z = (V - b.center) / b.half_width
        return float(ConvexHull(Z).volume * np.prod(b.half_width))

    def found_points(self) -> np.ndarray:
        """Every point of P the LPs have produced so far (vertices, support points), (m, p)."""
        return np.array(self._found).reshape(-1, self.dim)


def _chebyshev(H: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, float]:
    """Chebyshev centre of {z : H z <= h} with unit-norm rows (one LP)."""
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


def _vertex_certificates(ks, v, G, b, Hp, hp, tol, live, keep) -> list[int]:
    """Step 3 of :meth:`Polytope.nonredundant` for the sides ``ks`` (unit rows G z <= b), all
    active at the point v of P (prior rows Hp z <= hp; P inside [-1, 1]^p). In order: a side
    with a Farkas certificate from the other live sides active at v leaves ``live``; a side
    with a point beyond it by more than tol that satisfies every other live side, the prior
    and [-1, 1]^p (which every screened-out side contains) goes to ``keep``. Returns the sides
    with neither certificate."""
    p = G.shape[1]
    s, sp = b - G @ v, hp - Hp @ v                       # slacks at v
    ptol = TOUCH_TOL * (1.0 + np.abs(hp))
    prior_act = np.flatnonzero(sp <= ptol)
    # rays stay in [-1, 1]^p: rows of every live side, the prior and that box
    box = np.vstack([np.eye(p), -np.eye(p)])
    undecided = []
    for k in ks:
        act = np.flatnonzero(live & (s <= tol))
        act = act[act != k]
        M = np.vstack([G[act], Hp[prior_act]])
        lam, _ = scipy.optimize.nnls(M.T, G[k]) if len(M) else (np.zeros(0), 0.0)
        u = G[k] - M.T @ lam                             # the residual: g_j^T u <= 0 on M's rows
        if np.abs(u).max() <= 1e-11 and lam @ np.concatenate([b[act], hp[prior_act]]) <= b[k] + tol[k]:
            live[k] = False                              # g_k in the cone: redundant
            continue
        if np.abs(u).max() <= 1e-11:
            undecided.append(int(k))
            continue
        others = np.flatnonzero(live)
        others = others[others != k]
        R = np.vstack([G[others], Hp, box])
        slack = np.concatenate([s[others], sp, 1.0 - box @ v])
        rate = R @ u
        # rows active at v with a rate at rounding level are the cone's own (KKT: rate <= 0)
        rate[np.concatenate([np.isin(others, act), np.isin(np.arange(len(hp)), prior_act), np.zeros(2 * p, bool)])
             & (rate <= 1e-12 * np.linalg.norm(u))] = 0.0
        up = rate > 0
        t = np.min(np.maximum(slack[up], 0.0) / rate[up]) if up.any() else np.inf
        if np.isfinite(t) and t * float(G[k] @ u) - s[k] > tol[k]:
            keep[k] = True                               # v + t u: beyond k alone, by more than tol
        else:
            undecided.append(int(k))
    return undecided
