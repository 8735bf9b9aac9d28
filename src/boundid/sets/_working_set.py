"""Constraint generation for LPs with many rows (a warm-started simplex on a working set).

A large LP  min c^T x  s.t.  lo_i <= a_i^T x + g_i t <= up_i  (i in a pool of up to ~1e7 rows)
is solved on a small working set of rows; after each solve one pass over the whole pool finds
the most violated rows, which are added, and the LP is re-solved from its last basis (a row
added to an optimal basis keeps it dual feasible, so the dual simplex needs few steps). A point
that violates no pool row is optimal for the full LP (the working set is a relaxation).

The working set has few columns and up to a few thousand dense rows: it is solved by the dense
vertex simplex of :mod:`boundid.sets._vertex_lp` (10x faster per step there than HiGHS's sparse
simplex), and by HiGHS whenever that one gives up (no feasible start, an infeasible or
unbounded LP, a singular basis): HiGHS always gives the verdict on an infeasible or unbounded LP.

Three things keep the passes few at N = 1e7:

* several objectives are solved on the working set before one pass checks all their optima
  together (a matrix product over the pool instead of one matrix-vector product per objective);
* the first solves see a strided sample of the pool (``levels``), so most rows of the final
  working set are found on cheap passes (the sampling LP of Clarkson 1995, deterministic here);
* the pool is read in slices of ``CHUNK`` rows, never copied: a block holds the caller's raw
  rows ``A`` with a column scale ``d`` and a row scale ``s``, and row i acts on the LP
  variables as (A_i * d) / s_i (the well-scaled coordinates of :mod:`boundid.sets.polytope`);
  a :class:`StripBlock` does not even store its bounds and row norms: it computes them for the
  rows a pass or the working set asks for (compiled, one read of each row), so a change of
  coordinates costs nothing until a row is used.

:meth:`WorkingSetLP.supports` solves many objectives over the same polytope with as few LPs as
possible: the optimal basis of one LP proves the same vertex optimal for every direction in its
normal cone (the cone spanned by the outward normals of the constraints active in the basis).

A working set that only grows makes every simplex step pay for rows that no longer matter: after
many objectives (supports, strip extents) it holds half the pool. With ``max_rows`` it is cut back
(:meth:`WorkingSetLP.prune`) to its seed's rows and the rows of the last basis and of the newest
remembered optima when a call starts above that size; the passes add again what the next optima need. Six-joint UR5
study (p = 52, 9,592 strips): the outer ellipsoid's strip extents 32 s -> 14-16 s, the same ellipsoid.
"""

from __future__ import annotations

import functools
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import highspy
import numpy as np
from numba import njit
from threadpoolctl import ThreadpoolController

from boundid.errors import SolverError
from boundid.sets._vertex_lp import OPTIMAL, REACHED, vertex_simplex

_STATUS = highspy.HighsModelStatus
_AT_LOWER = highspy.HighsBasisStatus.kLower
_AT_UPPER = highspy.HighsBasisStatus.kUpper
#: a working-set row counts as satisfied within this, a multiplier as >= 0 above -this (the
#: vertex simplex's certificate; HiGHS, when it answers, uses the same two tolerances)
_FTOL = _DTOL = 1e-10
#: rows per slice of a pass over the pool (bounds the temporaries at N = 1e7)
CHUNK = 1 << 15
#: a direction d is in the normal cone of a basis when its multipliers are >= -_CONE_TOL |d|
_CONE_TOL = 1e-10
#: after each LP of :func:`supports` (without ``below``), the next this many pending directions are
#: checked for its normal cone: checking all k of them costs O(k n^2) per LP, O(k^2 n^2) in all
#: (6,000 supports of the UR5 study's polytope: 28 s, against 21 s with 256 and the same LPs to 1 %)
CONE_WINDOW = 256
#: optima (with their bases) a WorkingSetLP remembers as starts for new objectives
_ARCHIVE = 2048
#: a vertex past its target that violates pool rows: those rows join and the simplex starts again from
#: the same remembered optimum (a point of the pool's polytope while the pool's bounds have not
#: changed; else the simplex refuses the start and the next one is taken), at most this many times; a working
#: set cut back by prune() misses rows the first vertex past a target often violates (Panda, seven
#: joints: 324 of 2,419 strip sides settled at their targets with one try)
_REACH_TRIES = 3
#: the newest remembered bases whose rows a pruned working set keeps
KEEP_RECENT = 48
_BLAS = ThreadpoolController()


class _QuietHighs(highspy.Highs):
    """``highspy.Highs`` that never writes to the console, not even its banner.

    highspy 1.16's constructor builds the solver, then calls :meth:`enableCallbacks`, whose
    ``setCallback`` prints HiGHS's banner ("Running HiGHS 1.16.0 ...: Copyright ...", two lines,
    once per process) on the C stdout while ``output_flag`` still has its default, True: before
    any option can be set. This turns ``output_flag`` off at that hook, before the banner (older
    highspy, whose constructor does not call the hook, prints nothing before the first run)."""

    def enableCallbacks(self):
        self.setOptionValue("output_flag", False)
        super().enableCallbacks()


class _OneBlasThread:
    """BLAS limited to one thread while any thread of the process asks for it (a re-entrant, counted
    hold: threadpoolctl's limit is process-wide, so two threads each setting and restoring it would
    restore it in the wrong order)."""

    def __init__(self):
        self._lock = threading.Lock()
        self._holders = 0
        self._limiter = None

    def __enter__(self):
        with self._lock:
            if self._holders == 0:
                self._limiter = _BLAS.limit(limits=1, user_api="blas")
            self._holders += 1

    def __exit__(self, *exc):
        with self._lock:
            self._holders -= 1
            if self._holders == 0:
                self._limiter.restore_original_limits()
                self._limiter = None


#: hold it (``with ONE_BLAS_THREAD:``) around work that must run with one BLAS thread
ONE_BLAS_THREAD = _OneBlasThread()


def one_blas_thread(f):
    """Run ``f`` with BLAS limited to one thread. The LP loop alternates the simplex with many
    small BLAS calls; idle OpenBLAS threads spin between them and take the core the simplex needs
    (measured with HiGHS: LP bounds 2x faster at N = 1e5 and 1e6 with one BLAS thread, and no
    slower at 1e7)."""

    @functools.wraps(f)
    def run(*args, **kwargs):
        with ONE_BLAS_THREAD:
            return f(*args, **kwargs)

    return run


@dataclass
class Block:
    """Pool rows lo <= (A_i * d) x[:p] / s_i + g_i x[p] <= up_i.

    A : (m, p) raw rows, referenced, not copied (``d`` None: no column scale, ``s`` None: 1).
    lo, up : (m,) bounds in the scaled row's units (+-inf allowed).
    g : (m,) coefficients of the extra column, already divided by s (None: no extra column).
    """

    A: np.ndarray
    lo: np.ndarray
    up: np.ndarray
    g: np.ndarray | None = None
    d: np.ndarray | None = None
    s: np.ndarray | None = None
    _kind: str | None = field(default=None, repr=False)
    _mid: np.ndarray | None = field(default=None, repr=False)
    _half: np.ndarray | None = field(default=None, repr=False)

    @property
    def m(self) -> int:
        return self.A.shape[0]

    def violation(self, sl, X: np.ndarray) -> np.ndarray:
        """Distance of each row ``sl`` outside [lo, up] at the columns of X (negative inside),
        computed in place: |act - mid| - half for two-sided rows, act - up or lo - act otherwise."""
        V = self.activity(sl, X)
        if self._kind is None:
            lo_fin, up_fin = np.isfinite(self.lo), np.isfinite(self.up)
            self._kind = "two" if lo_fin.all() and up_fin.all() else "up" if not lo_fin.any() else \
                "lo" if not up_fin.any() else "mixed"
            if self._kind == "two":
                self._mid, self._half = 0.5 * (self.lo + self.up), 0.5 * (self.up - self.lo)
        if self._kind == "two":
            V -= self._mid[sl, None]
            np.abs(V, out=V)
            V -= self._half[sl, None]
        elif self._kind == "up":
            V -= self.up[sl, None]
        elif self._kind == "lo":
            np.subtract(self.lo[sl, None], V, out=V)
        else:
            V = np.maximum(self.lo[sl, None] - V, V - self.up[sl, None])
        return V

    def bounds(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lo, up) of pool rows ``idx``."""
        return self.lo[idx], self.up[idx]

    def set_bounds(self, k: int, lo: float, up: float) -> None:
        """Change the bounds of pool row k."""
        self.lo[k], self.up[k] = lo, up
        self._kind = None

    def rows_bounds(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rows, lo, up) of pool rows ``idx``: :meth:`rows` and :meth:`bounds` together."""
        return (self.rows(idx), *self.bounds(idx))

    def rows(self, idx: np.ndarray) -> np.ndarray:
        """The effective coefficient rows of pool rows ``idx``, (len(idx), p [+ 1])."""
        R = self.A[idx]
        if self.d is not None:
            R = R * self.d
        if self.s is not None:
            R = R / self.s[idx, None]
        if self.g is not None:
            R = np.hstack([R, self.g[idx, None]])
        return R

    def activity(self, sl, X: np.ndarray) -> np.ndarray:
        """Row activities of rows ``sl`` (a slice or index array) at the columns of X (n_cols, k)."""
        p = self.A.shape[1]
        Z = X[:p] if self.d is None else self.d[:, None] * X[:p]
        R = self.A[sl] @ Z
        if self.s is not None:
            R /= self.s[sl, None]
        if self.g is not None:
            R += self.g[sl, None] * X[p][None, :]
        return R


@njit(cache=True)
def frame_rows(W: np.ndarray, y: np.ndarray, origin: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Strips seen from theta = origin + scale * z, for the rows of W (m, p): (r, n), both (m,),
    r_k = y_k - w_k^T origin, n_k = |w_k * scale| (1 for an all-zero row). One read of each row,
    a fixed order of operations: the same row always gives the same bits (passes and working
    set agree)."""
    m, p = W.shape
    r, n = np.empty(m), np.empty(m)
    for i in range(m):
        acc, ss = y[i], 0.0
        for j in range(p):
            w = W[i, j]
            acc -= w * origin[j]
            v = w * scale[j]
            ss += v * v
        r[i] = acc
        n[i] = np.sqrt(ss) if ss > 0.0 else 1.0
    return r, n


@njit(cache=True)
def col_rms(W: np.ndarray, e: np.ndarray) -> np.ndarray:
    """RMS over the rows of w_kj / e_k for each column j, (p,) (one read of W)."""
    N, p = W.shape
    ss = np.zeros(p)
    for i in range(N):
        q = 1.0 / (e[i] * e[i])
        for j in range(p):
            ss[j] += W[i, j] * W[i, j] * q
    return np.sqrt(ss / max(N, 1))


@njit(cache=True)
def box_reach(W, y, e, rows, center, half, level, tol):
    """Which strips |y_k - w_k^T theta| <= level e_k do not contain the box |theta - center| <=
    half (element-wise): max over the box of |y_k - w_k^T theta| = |r_k| + |w_k|^T half exceeds
    level e_k - tol (n_k + level e_k + |r_k|), r_k = y_k - w_k^T center, n_k = |w_k * half| (the
    test of the normalised strip with relative margin ``tol``: a strip not kept contains the
    box). ``rows``: the strips to test (empty: all). Returns a boolean mask over them."""
    every = rows.size == 0
    m = W.shape[0] if every else rows.size
    p = W.shape[1]
    keep = np.empty(m, dtype=np.bool_)
    for k in range(m):
        i = k if every else rows[k]
        r, a, ss = y[i], 0.0, 0.0
        for j in range(p):
            w = W[i, j]
            r -= w * center[j]
            v = abs(w) * half[j]
            a += v
            ss += v * v
        n = np.sqrt(ss) if ss > 0.0 else 1.0
        le = level * e[i]
        keep[k] = abs(r) + a > le - tol * (n + le + abs(r))
    return keep


@njit(cache=True)
def max_ratio(W, y, e, X):
    """max_k |y_k - w_k^T x| / e_k for each row x of X (m, p), over every row k (one read)."""
    N, p = W.shape
    out = np.zeros(X.shape[0])
    for i in range(N):
        for c in range(X.shape[0]):
            acc = y[i]
            for j in range(p):
                acc -= W[i, j] * X[c, j]
            q = abs(acc) / e[i]
            if q > out[c]:
                out[c] = q
    return out


@njit(cache=True)
def level_ratios(W, y, e, origin, dz, theta):
    """The consistency LP's answer on the original data: rho_k = |r_k - w_k^T dz| / e_k with
    r_k = y_k - w_k^T origin (as in :func:`frame_rows`), and max_k (|y_k| + |w_k|^T |theta|) / e_k
    (the size of the residual's rounding). Returns (rho (N,), that max)."""
    N, p = W.shape
    rho = np.empty(N)
    mag = 0.0
    for i in range(N):
        r, a, s = y[i], 0.0, abs(y[i])
        for j in range(p):
            w = W[i, j]
            r -= w * origin[j]
            a += w * dz[j]
            s += abs(w) * abs(theta[j])
        rho[i] = abs(r - a) / e[i]
        s /= e[i]
        if s > mag:
            mag = s
    return rho, mag


#: a StripBlock of at most this many rows keeps their r_k and n_k (16 MB at the limit); above it they are
#: recomputed at each pass, so that nothing of size N is stored for the 1e7-row problems
RN_CACHE_ROWS = 1_000_000
#: an active part of a strip pool of at most this many rows is copied once into a block of its own
#: (WorkingSetLP._gather): 100,000 rows of p = 70 are 56 MB
GATHER_ROWS = 100_000


class StripBlock:
    """Pool rows of the strips |y_k - w_k^T theta| <= level e_k seen from theta = origin + scale z,
    computed on demand (r_k, n_k of :func:`frame_rows`, kept up to RN_CACHE_ROWS rows).

    side 0: lo_k <= (w_k * scale)^T z / n_k <= up_k with lo, up = (r_k -+ level e_k) / n_k.
    side +1 / -1: the two halves of the consistency LP over (z, t), rows
    [w_k * scale, +-e_k] / s_k with s_k = (n_k^2 + e_k^2)^(1/2):  w z + e t >= r  (side +1,
    lo = r / s) and  w z - e t <= r  (side -1, up = r / s).
    """

    def __init__(self, W, y, e, origin, scale, side: int = 0, level: float = 1.0):
        self.W, self.y, self.e = W, y, e
        self.origin, self.scale = np.asarray(origin, dtype=float), np.asarray(scale, dtype=float)
        self.side, self.level = side, float(level)
        #: r_k, n_k of every row, kept when there are at most RN_CACHE_ROWS of them (16 bytes a row):
        #: a pass over the pool then reads W alone (six-joint UR5, 9,592 rows: 19 s of 240 were
        #: spent recomputing them, 18,000 passes)
        self._r_n = frame_rows(np.ascontiguousarray(W), y, self.origin, self.scale) \
            if W.shape[0] <= RN_CACHE_ROWS else None

    @property
    def m(self) -> int:
        return self.W.shape[0]

    def subset(self, idx: np.ndarray) -> StripBlock:
        """The rows ``idx`` as a block of their own, W's rows copied contiguous (r_k, n_k too, when kept)."""
        sub = StripBlock.__new__(StripBlock)
        sub.W, sub.y, sub.e = np.ascontiguousarray(self.W[idx]), self.y[idx], self.e[idx]
        sub.origin, sub.scale, sub.side, sub.level = self.origin, self.scale, self.side, self.level
        sub._r_n = None if self._r_n is None else (self._r_n[0][idx], self._r_n[1][idx])
        if sub._r_n is None and sub.W.shape[0] <= RN_CACHE_ROWS:
            sub._r_n = frame_rows(sub.W, sub.y, sub.origin, sub.scale)
        return sub

    def _rn(self, sl) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        Ws = np.ascontiguousarray(self.W[sl])
        if self._r_n is not None:
            return Ws, self._r_n[0][sl], self._r_n[1][sl]
        r, n = frame_rows(Ws, self.y[sl], self.origin, self.scale)
        return Ws, r, n

    def bounds(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, r, n = self._rn(idx)
        e = self.e[idx]
        if self.side == 0:
            return (r - self.level * e) / n, (r + self.level * e) / n
        s = np.hypot(n, e)
        return (r / s, np.full(r.size, np.inf)) if self.side > 0 else (np.full(r.size, -np.inf), r / s)

    def rows(self, idx: np.ndarray) -> np.ndarray:
        return self.rows_bounds(idx)[0]

    def rows_bounds(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rows, lo, up) of pool rows ``idx`` (:meth:`rows`, :meth:`bounds`) from one read of them."""
        Ws, r, n = self._rn(idx)
        e = self.e[idx]
        if self.side == 0:
            return Ws * self.scale / n[:, None], (r - self.level * e) / n, (r + self.level * e) / n
        s = np.hypot(n, e)
        R = np.hstack([Ws * self.scale, self.side * e[:, None]]) / s[:, None]
        return (R, r / s, np.full(r.size, np.inf)) if self.side > 0 else (R, np.full(r.size, -np.inf), r / s)

    def violation(self, sl, X: np.ndarray) -> np.ndarray:
        """Distance of each row ``sl`` outside its bounds at the columns of X (negative inside)."""
        Ws, r, n = self._rn(sl)
        p = Ws.shape[1]
        V = Ws @ (self.scale[:, None] * X[:p])
        e = self.e[sl]
        if self.side == 0:
            V -= r[:, None]
            np.abs(V, out=V)
            V -= self.level * e[:, None]
            V /= n[:, None]
            return V
        V += self.side * e[:, None] * X[p][None, :]         # activity times s
        V -= r[:, None]
        V *= -self.side / np.hypot(n, e)[:, None]
        return V


def sample_levels(m: int, smallest: int = 10_000, ratio: int = 16) -> tuple[int, ...]:
    """Sample sizes m / ratio^k (k >= 1) down to ``smallest``, ascending: the stages of a
    constraint generation over m rows (each stage's working set seeds the next)."""
    sizes = []
    n = m // ratio
    while n >= smallest:
        sizes.append(n)
        n //= ratio
    return tuple(sizes[::-1])


def strided_sample(m: int, n: int) -> np.ndarray:
    """About n of the indices 0..m-1, evenly strided (deterministic; rows of a recording are in
    time order, so a stride sees the whole experiment)."""
    return np.arange(0, m, max(1, -(-m // n)), dtype=np.int64)


class LPStatusError(Exception):
    """The working-set LP is infeasible or unbounded (``status`` says which)."""

    def __init__(self, status: str):
        super().__init__(status)
        self.status = status


class WorkingSetLP:
    """An LP over ``n_cols`` columns whose rows are generated from ``blocks``.

    Parameters
    ----------
    blocks : list of Block
        The pool.
    col_lo, col_hi : (n_cols,) arrays
        Column bounds (+-inf allowed).
    seed : list of (block index, row indices)
        Rows put in the working set before the first solve (they must make it bounded for
        the objectives asked, or the solve reports "unbounded").
    tol : float
        Violation (in the scaled row's units) below which a pool row counts as satisfied.
    batch : int
        At most this many of the most violated rows are added per objective and round.
    max_rows : int or None
        When a call starts with more working-set rows than this, the working set is cut back
        (:meth:`prune`); None: it only grows.
    keep : list of (block index, row indices) or None
        Rows no prune removes (default: ``seed``, the rows that keep the LPs bounded).
    """

    def __init__(self, blocks, col_lo, col_hi, seed=(), tol: float = 1e-9, batch: int = 32,
                 max_rounds: int = 10_000, max_rows: int | None = None, keep=None):
        self.blocks = list(blocks)
        self.n_cols = len(col_lo)
        self.tol = tol
        self.batch = batch
        self.max_rounds = max_rounds
        self.max_rows = max_rows
        #: the pool's rows numbered across blocks: pool row k of block b is key _offset[b] + k
        self._offset = np.concatenate([[0], np.cumsum([b.m for b in self.blocks])]).astype(np.int64)
        self.in_ws = [np.zeros(b.m, dtype=bool) for b in self.blocks]
        #: working-set row of each pool row (read only where in_ws; never filled)
        self.row_of = [np.empty(b.m, dtype=np.int64) for b in self.blocks]
        #: the part of each block's pool that passes look at (None: all of it); the caller may
        #: leave out rows that no future optimum can violate (e.g. strips containing a box that
        #: contains the working set's polytope)
        self.active: list[np.ndarray | None] = [None] * len(self.blocks)
        #: per block, (the active array, its rows as a block of their own): see violators
        self._gathered: dict[int, tuple[np.ndarray, StripBlock]] = {}
        self.n_rows = 0
        self.n_solves = 0
        #: solves that HiGHS answered because the vertex simplex gave up (see _solve)
        self.n_highs = 0
        self.n_passes = 0
        #: the LP in the dense form of :mod:`boundid.sets._vertex_lp`: the column bounds as unit
        #: rows 0 .. n_cols - 1, then working-set row r as row n_cols + r
        self._A = np.eye(self.n_cols)
        self._lo, self._up = np.array(col_lo, dtype=float), np.array(col_hi, dtype=float)
        #: the key of each row of _A: -1 - j for column bound j, else its pool key (see _offset)
        self._key = -1 - np.arange(self.n_cols, dtype=np.int64)
        #: the last optimal basis (rows of _A, sides) and its vertex; None before the first solve
        self._act: np.ndarray | None = None
        self._side: np.ndarray | None = None
        self._x: np.ndarray | None = None
        #: the last optimal basis of each objective of a multi-objective minimize_many (by the
        #: bytes of its cost), so that each re-solve starts at its own vertex, not at the last one
        self._bases: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        #: optima of the pool found so far, and vertices of it met at a target, with their bases as
        #: (keys of their rows, sides) (the newest _ARCHIVE, a ring): a new objective starts at the
        #: best of them (see _solve), its rows put back in the working set if they were pruned
        self._archive_x = np.empty((_ARCHIVE, self.n_cols))
        self._archive: list[tuple[np.ndarray, np.ndarray]] = []
        self._n_archived = 0
        #: HiGHS's copy of the LP, built the first time the vertex simplex gives up
        self._h: highspy.Highs | None = None
        for b, rows in seed:
            self.add_rows(b, np.asarray(rows, dtype=np.int64))
        #: the keys of the rows no prune removes
        self._keep = np.unique(np.concatenate([self._offset[b] + np.asarray(rows, dtype=np.int64)
                                               for b, rows in (seed if keep is None else keep)] or
                                              [np.zeros(0, dtype=np.int64)]))

    # ------------------------------------------------------------------ working set
    def add_rows(self, b: int, rows: np.ndarray) -> None:
        """Add pool rows ``rows`` of block ``b`` to the working set (duplicates skipped)."""
        rows = np.asarray(rows, dtype=np.int64)
        rows = rows[~self.in_ws[b][rows]]
        if rows.size == 0:
            return
        rows = np.unique(rows)
        blk = self.blocks[b]
        vals, blo, bup = blk.rows_bounds(rows)
        if vals.shape[1] < self.n_cols:
            vals = np.hstack([vals, np.zeros((rows.size, self.n_cols - vals.shape[1]))])
        vals = np.asarray(vals, dtype=float)
        if self._h is not None:
            _highs_rows(self._h, vals, blo, bup)
        self.in_ws[b][rows] = True
        self.row_of[b][rows] = np.arange(self.n_rows, self.n_rows + rows.size)
        self._A = np.vstack([self._A, vals])
        self._lo = np.concatenate([self._lo, blo])
        self._up = np.concatenate([self._up, bup])
        self._key = np.concatenate([self._key, self._offset[b] + rows])
        self.n_rows += rows.size

    def _block_of(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(block index, row in that block) of each pool key (>= 0; see _offset)."""
        b = np.searchsorted(self._offset, keys, side="right") - 1
        return b, keys - self._offset[b]

    def _rows_of_keys(self, keys: np.ndarray) -> np.ndarray:
        """The rows of _A with these keys (see _offset), pool rows added to the working set where missing."""
        keys = np.asarray(keys, dtype=np.int64)
        pool = keys >= 0
        b, k = self._block_of(keys)
        for bb in np.unique(b[pool]):
            self.add_rows(int(bb), k[pool & (b == bb)])
        out = -1 - keys
        for bb in np.unique(b[pool]):
            sel = pool & (b == bb)
            out[sel] = self.n_cols + self.row_of[bb][k[sel]]
        return out

    def keep_rows(self) -> list[tuple[int, np.ndarray]]:
        """The rows no prune removes, as (block index, row indices) (the ``keep`` of a copy)."""
        b, k = self._block_of(self._keep)
        return [(int(bb), k[b == bb]) for bb in np.unique(b)]

    def in_ws_key(self, keys: np.ndarray) -> np.ndarray:
        """Whether each pool key (>= 0) is in the working set."""
        b, k = self._block_of(keys)
        out = np.zeros(keys.size, dtype=bool)
        for bb in np.unique(b):
            sel = b == bb
            out[sel] = self.in_ws[bb][k[sel]]
        return out

    def prune(self) -> None:
        """Cut the working set back to the column bounds, the rows it must keep (``keep``), the last
        basis's rows and those of the KEEP_RECENT newest remembered optima. These may exceed
        ``max_rows``, and then every call prunes: that measured better than keeping fewer (the Panda's
        outer ellipsoid took 17 % more simplex steps with at most half of ``max_rows`` kept). The next
        solves start from such a basis or from an older remembered optimum (whose rows come back with
        it), and the passes over the pool add again the rows they need: a working set that only grows
        makes every simplex step pay for rows that no longer matter (UR5, six joints: 4,800 rows, where
        the supports of nearby directions need about 1,000)."""
        n = self.n_cols
        keep = np.zeros(n + self.n_rows, dtype=bool)
        keep[:n] = True
        if self._act is not None:
            keep[self._act] = True
        recent = [self._archive[(self._n_archived - 1 - j) % _ARCHIVE][0]
                  for j in range(min(KEEP_RECENT, len(self._archive)))]
        keys = np.concatenate([self._keep, *recent])
        keys = np.unique(keys[keys >= 0])                 # the column bounds are kept already
        keep[self._rows_of_keys(keys[self.in_ws_key(keys)])] = True
        new_row = np.cumsum(keep) - 1
        for b in range(len(self.blocks)):
            ks = np.flatnonzero(self.in_ws[b])
            rows = n + self.row_of[b][ks]
            self.in_ws[b][ks[~keep[rows]]] = False
            self.row_of[b][ks[keep[rows]]] = new_row[rows[keep[rows]]] - n
        self._A, self._lo, self._up, self._key = self._A[keep], self._lo[keep], self._up[keep], self._key[keep]
        self.n_rows = int(keep.sum()) - n
        if self._act is not None:
            self._act = new_row[self._act]
        self._bases = {}
        self._h = None                              # HiGHS's copy is rebuilt from these rows if needed

    def take_basis(self, other: WorkingSetLP) -> None:
        """Start from ``other``'s bases (its last one, and the one kept for each objective): the
        same pool rows in the same constraint set, seen in other coordinates (rescaled columns
        and rows, shifted bounds), so the vertices and their bases carry over and the next
        solves start where ``other`` stopped. Needs every working-set row of ``other`` here."""
        if other._act is None:
            return
        n = self.n_cols
        here = np.full(n + other.n_rows, -1, dtype=np.int64)    # row of _A here for each of other's
        here[:n] = np.arange(n)
        for b in range(len(self.blocks)):
            ks = np.flatnonzero(other.in_ws[b])
            if not np.all(self.in_ws[b][ks]):
                return
            here[n + other.row_of[b][ks]] = n + self.row_of[b][ks]
        self._act, self._side, self._x = here[other._act], other._side.copy(), None
        self._bases = {k: (here[a], s.copy()) for k, (a, s) in other._bases.items()}
        if other._archive:                        # their rows at once (one copy of _A, not one per basis)
            keys = np.concatenate([k for k, _ in other._archive])
            self._rows_of_keys(np.unique(keys[keys >= 0]))
        for keys, s in other._archive:            # the vertices, recomputed in these coordinates
            act = self._rows_of_keys(keys)
            N = s[:, None] * self._A[act]
            try:
                x = np.linalg.solve(N, np.where(s > 0, self._up[act], -self._lo[act]))
            except np.linalg.LinAlgError:
                continue
            self._archive_add(x, (act, s.copy()))

    def clone(self) -> WorkingSetLP:
        """A second engine over the same pool (the blocks shared, read only) with this one's working
        set, bases and remembered optima, for another thread: each engine serves one thread at a time
        (:func:`reaches_in_threads`)."""
        other = WorkingSetLP(self.blocks, self.col_lo.copy(), self.col_hi.copy(),
                             seed=[(b, self.ws_rows(b)) for b in range(len(self.blocks))], tol=self.tol,
                             batch=self.batch, max_rounds=self.max_rounds, max_rows=self.max_rows,
                             keep=self.keep_rows())
        other.active = list(self.active)
        other.take_basis(self)
        return other

    def take_rows(self, other: WorkingSetLP) -> None:
        """Add to the working set the pool rows ``other`` (an engine over the same pool) has and this one lacks."""
        for b in range(len(self.blocks)):
            self.add_rows(b, other.ws_rows(b))

    @property
    def col_lo(self) -> np.ndarray:
        """Column lower bounds (n_cols,): the first rows of the dense form (a view)."""
        return self._lo[: self.n_cols]

    @property
    def col_hi(self) -> np.ndarray:
        """Column upper bounds (n_cols,): the first rows of the dense form (a view)."""
        return self._up[: self.n_cols]

    def set_col_bounds(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Change the column bounds (+-inf allowed; HiGHS's infinity is IEEE inf)."""
        self._lo[: self.n_cols], self._up[: self.n_cols] = lo, hi
        if self._h is not None:
            self._h.changeColsBounds(self.n_cols, np.arange(self.n_cols, dtype=np.int32), self.col_lo, self.col_hi)

    def ws_rows(self, b: int) -> np.ndarray:
        """Pool indices of block ``b`` in the working set."""
        return np.flatnonzero(self.in_ws[b])

    def set_bounds(self, b: int, k: int, lo: float, up: float) -> None:
        """Change the bounds of pool row k of block b (and of its working-set copy)."""
        self.blocks[b].set_bounds(k, lo, up)
        if self.in_ws[b][k]:
            r = self.row_of[b][k]
            self._lo[self.n_cols + r], self._up[self.n_cols + r] = lo, up
            if self._h is not None:
                self._h.changeRowBounds(int(r), lo, up)

    # ------------------------------------------------------------------ passes over the pool
    def violators(self, X: np.ndarray, batch: int | None = None) -> list[list[tuple[int, np.ndarray]]]:
        """For each column x of X (n_cols, k): the ``batch`` (default ``self.batch``) most violated
        pool rows (violation above ``tol``) not in the working set, as a list of (block, rows);
        one pass over the pool. Rows in the working set are the solver's to satisfy, to its own
        tolerance."""
        self.n_passes += 1
        batch = self.batch if batch is None else batch
        k = X.shape[1]
        found: list[list[tuple[int, np.ndarray, np.ndarray]]] = [[] for _ in range(k)]
        for b, blk in enumerate(self.blocks):
            pool = self.active[b]
            src, gathered = self._gather(b, pool)
            m = blk.m if pool is None else pool.size
            for start in range(0, m, CHUNK):
                stop = min(m, start + CHUNK)
                sl = slice(start, stop) if pool is None or gathered else pool[start:stop]
                V = src.violation(sl, X)
                hit = V > self.tol
                if not hit.any():
                    continue
                idx = np.arange(start, stop) if pool is None else pool[start:stop]
                hit &= ~self.in_ws[b][idx][:, None]
                for j in np.flatnonzero(hit.any(axis=0)):
                    sel = np.flatnonzero(hit[:, j])
                    if sel.size > batch:
                        sel = sel[np.argpartition(V[sel, j], -batch)[-batch:]]
                    found[j].append((b, idx[sel], V[sel, j]))
        out = []
        for parts in found:
            if not parts:
                out.append([])
                continue
            vals = np.concatenate([v for _, _, v in parts])
            cut = np.partition(vals, vals.size - batch)[vals.size - batch] if vals.size > batch else -np.inf
            out.append([(b, rows[v >= cut]) for b, rows, v in parts])
        return out

    def _gather(self, b: int, pool: np.ndarray | None):
        """(the block to pass over, gathered): block b itself, or, when only its rows ``pool`` are
        active, at most GATHER_ROWS of them and it is a StripBlock, those rows as a block of their own,
        made once per active array: every pass then reads contiguous rows instead of copying them
        (six-joint UR5, outer ellipsoid: 4,700 passes, 2.1 s of copies of the 8,548 rows reaching the
        box)."""
        blk = self.blocks[b]
        if pool is None or not isinstance(blk, StripBlock) or pool.size > GATHER_ROWS:
            return blk, False
        key, sub = self._gathered.get(b, (None, None))
        if key is not pool:
            sub = blk.subset(pool)
            self._gathered[b] = (pool, sub)
        return sub, True

    # ------------------------------------------------------------------ solves
    def _solve(self, cost: np.ndarray, keep_basis: bool = False, new: bool = False,
               target: float = -np.inf) -> tuple[np.ndarray, bool]:
        """(x, reached): argmin of cost^T x on the working set, reached False; ``keep_basis``: start
        from, and keep, the last basis of this same objective; ``new``: the first solve of this
        objective. ``target``: a vertex with cost^T x <= target on the way is answer enough if it
        satisfies the whole pool (one pass); then reached is True and x that vertex, not the argmin
        (else the simplex goes on from it to the argmin).

        The vertex simplex (:mod:`boundid.sets._vertex_lp`) starts from the last basis (primal
        feasible for a new objective, dual feasible after rows were added for the same one), or
        else from the corner of the column bounds that the objective picks (dual feasible when
        that corner is finite). A new objective starts instead at the remembered optimum of the
        pool with the lowest cost, if it beats the last one: a primal feasible start already
        close to the answer (strip extents of the UR5 study: half the simplex steps).
        When it gives up, HiGHS solves the same LP and gives the verdict on an infeasible or
        unbounded one."""
        cost = np.asarray(cost, dtype=float)
        d = -cost
        starts, archived = [], False
        kept = self._bases.get(cost.tobytes()) if keep_basis else None
        if new and kept is None and self._archive:
            vals = self._archive_x[: len(self._archive)] @ cost
            j = int(np.argmin(vals))
            if self._x is None or vals[j] < cost @ self._x:
                keys, side = self._archive[j]
                starts.append((self._rows_of_keys(keys), side))
                archived = True
        if kept is not None or self._act is not None:
            starts.append(kept if kept is not None else (self._act, self._side))
        corner = np.where(d >= 0, 1.0, -1.0)
        if np.all(np.isfinite(np.where(corner > 0, self.col_hi, self.col_lo))):
            starts.append((np.arange(self.n_cols), corner))
        max_steps = max(1000, 5 * self._A.shape[0])
        for k, (act0, side0) in enumerate(starts):
            tries = _REACH_TRIES if k == 0 and archived and np.isfinite(target) else 1
            for attempt in range(tries):
                act, side = act0.copy(), side0.copy()
                status, x, _, _ = vertex_simplex(self._A, self._lo, self._up, d, act, side, _FTOL, _DTOL,
                                                 max_steps, -target)
                if status != REACHED:
                    break
                worst = self.violators(x[:, None])[0]
                if not worst:
                    self._act, self._side, self._x = act, side, None    # not an optimal basis
                    self._archive_add(x, (act.copy(), side.copy()))
                    self.n_solves += 1
                    return x.copy(), True
                if attempt + 1 < tries:     # the rows it violates join; again from the same (feasible) start
                    for b, rows in worst:
                        self.add_rows(b, rows)
            if status == REACHED:
                status, x, _, _ = vertex_simplex(self._A, self._lo, self._up, d, act, side, _FTOL, _DTOL,
                                                 max_steps, np.inf)
            if status == OPTIMAL:
                self._act, self._side, self._x = act, side, x
                break
        else:
            x = self._highs_solve(cost)
        self.n_solves += 1
        if keep_basis and self._act is not None:
            self._bases[cost.tobytes()] = (self._act, self._side)
        return x.copy(), False

    def _highs_solve(self, cost: np.ndarray) -> np.ndarray:
        """argmin of cost^T x on the working set by HiGHS's dual simplex, which also takes its
        basis as the vertex simplex's next start; raises LPStatusError if the LP is infeasible
        or unbounded."""
        self.n_highs += 1
        if self._h is None:
            self._h = h = _QuietHighs()
            for name, val in (("output_flag", False), ("presolve", "off"), ("solver", "simplex"),
                              ("primal_feasibility_tolerance", _FTOL), ("dual_feasibility_tolerance", _DTOL),
                              ("threads", 1)):
                h.setOptionValue(name, val)
            h.addVars(self.n_cols, self.col_lo, self.col_hi)
            n = self.n_cols
            _highs_rows(h, self._A[n:], self._lo[n:], self._up[n:])
        h = self._h
        h.changeColsCost(self.n_cols, np.arange(self.n_cols, dtype=np.int32), cost)
        h.run()
        st = h.getModelStatus()
        if st == _STATUS.kNotset:
            # HiGHS stopped before solving (seen rarely after many warm re-solves: it rejects
            # its own carried basis): the same LP once more from scratch
            h.clearSolver()
            h.run()
            st = h.getModelStatus()
        if st == _STATUS.kInfeasible:
            raise LPStatusError("infeasible")
        if st in (_STATUS.kUnbounded, _STATUS.kUnboundedOrInfeasible):
            raise LPStatusError("unbounded" if st == _STATUS.kUnbounded else "unbounded_or_infeasible")
        if st != _STATUS.kOptimal:
            raise SolverError(f"HiGHS stopped with status {h.modelStatusToString(st)} on a {self.n_rows}-row "
                              "working set of a problem already solved in well-scaled coordinates; report "
                              "this case (the data, or W, y, e_max) so the scaling can be improved.")
        basis = h.getBasis()
        status = np.array([int(v.value) for v in list(basis.col_status) + list(basis.row_status)])
        at = np.flatnonzero((status == int(_AT_UPPER.value)) | (status == int(_AT_LOWER.value)))
        self._act, self._side = (at, np.where(status[at] == int(_AT_UPPER.value), 1.0, -1.0)) \
            if at.size == self.n_cols else (None, None)
        self._x = x = np.array(h.getSolution().col_value)
        return x

    @one_blas_thread
    def minimize_many(self, costs: np.ndarray, levels: tuple[int, ...] = ()) -> np.ndarray:
        """argmin of cost^T x over the full pool for each row of ``costs`` (k, n_cols) -> (k, n_cols).

        Each round solves every unfinished objective on the working set, then one pass checks
        all their optima and adds each one's most violated rows. ``levels``: sizes of strided
        samples of block 0 to run on first (ascending; the full pool always comes last).
        """
        return self._minimize(np.atleast_2d(np.asarray(costs, dtype=float)), levels)[0]

    @one_blas_thread
    def reach(self, cost: np.ndarray, target: float) -> tuple[np.ndarray, bool]:
        """(x, reached): a point of the pool's polytope with cost^T x <= ``target`` met by the simplex on
        its first way to the argmin (reached True), else the argmin over the pool (reached False)."""
        X, reached = self._minimize(np.asarray(cost, dtype=float)[None, :], (), np.array([target]))
        return X[0], bool(reached[0])

    def _minimize(self, costs: np.ndarray, levels: tuple[int, ...] = (),
                  targets: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(X, reached) of :meth:`minimize_many`; ``targets`` (k,): the first solve of each objective on
        the full pool may stop at a vertex of the pool with cost^T x <= its target (see :meth:`_solve`)."""
        if self.max_rows is not None and self.n_rows > self.max_rows:
            self.prune()
        X = np.empty((costs.shape[0], self.n_cols))
        reached = np.zeros(costs.shape[0], dtype=bool)
        m0 = self.blocks[0].m if self.blocks else 0
        keep = self.active[0]
        stages = [strided_sample(m0, n) for n in levels] + [keep]
        for s, stage in enumerate(stages):
            self.active[0] = stage
            pending = np.arange(costs.shape[0])
            for r in range(self.max_rounds):
                mark = self.n_rows
                for i in pending:
                    target = targets[i] if targets is not None and r == 0 and s == len(levels) else -np.inf
                    X[i], reached[i] = self._solve(costs[i], keep_basis=costs.shape[0] > 1, new=r == 0,
                                                   target=target)
                worst = self.violators(X[pending].T, batch=max(8, self.batch // max(1, pending.size // 4)))
                late = self._violates_rows_since(X[pending], mark)
                still = []
                for i, w, lt in zip(pending, worst, late, strict=True):
                    for b, rows in w:
                        self.add_rows(b, rows)
                    if w or lt:
                        still.append(i)
                pending = np.array(still, dtype=int)
                if pending.size == 0:
                    break
            else:
                raise SolverError(f"constraint generation did not converge in {self.max_rounds} rounds.")
        self._remember(costs, X, keep=~reached)
        return X, reached

    def _violates_rows_since(self, X: np.ndarray, mark: int) -> np.ndarray:
        """For each row x of X (k, n_cols): whether it violates (by more than ``tol``) a working-set row
        added after the working set had ``mark`` rows. A solve may add rows (a remembered start's pruned
        rows, the rows a vertex past its target violates), which an objective solved before it in the
        same round never saw, and which the pass over the pool skips, as rows of the working set."""
        lo_, up_ = self.n_cols + mark, self.n_cols + self.n_rows
        if lo_ == up_:
            return np.zeros(len(X), dtype=bool)
        AX = self._A[lo_:up_] @ X.T
        with np.errstate(invalid="ignore"):
            bad = (AX > self._up[lo_:up_, None] + self.tol) | (AX < self._lo[lo_:up_, None] - self.tol)
        return bad.any(axis=0)

    def _remember(self, costs: np.ndarray, X: np.ndarray, keep: np.ndarray) -> None:
        """Archive the optima X of the pool (one per row of ``costs``, where ``keep``) with their bases."""
        for cost, x in zip(costs[keep], X[keep], strict=True):
            if costs.shape[0] > 1:                  # each objective kept its own last basis
                basis = self._bases.get(cost.tobytes())
            elif self._x is not None and np.array_equal(x, self._x):
                basis = (self._act, self._side)
            else:                                   # the last basis is not this answer's
                basis = None
            if basis is not None and basis[0] is not None:
                self._archive_add(x, basis)

    def _archive_add(self, x: np.ndarray, basis: tuple[np.ndarray, np.ndarray]) -> None:
        """Put (x, basis) in the ring, over the oldest entry once it is full."""
        k = self._n_archived % _ARCHIVE
        self._archive_x[k] = x
        basis = (self._key[basis[0]], basis[1].copy())
        if k < len(self._archive):
            self._archive[k] = basis
        else:
            self._archive.append(basis)
        self._n_archived += 1

    def minimize(self, cost: np.ndarray) -> tuple[np.ndarray, float]:
        """argmin and min of cost^T x over the full pool (cost: (n_cols,))."""
        x = self.minimize_many(np.asarray(cost, dtype=float)[None, :])[0]
        return x, float(np.asarray(cost, dtype=float) @ x)

    def active_normals(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The constraints of the optimal basis at x, the last solve's answer, as (N, own, opp):
        outward normals N (n_cols, n_cols), so that x is optimal for every direction in their
        cone; own, opp (n_cols,): every point of the working set's polytope has N x <= own and
        -N x <= opp (the other side of the same row or column bound; inf if it has none).
        None if x is not the last answer or that answer has no basis of n_cols constraints."""
        if self._act is None or self._x is None or not np.array_equal(x, self._x):
            return None
        act, up = self._act, self._side > 0
        lo_, up_ = self._lo[act], self._up[act]
        return self._side[:, None] * self._A[act], np.where(up, up_, -lo_), np.where(up, -lo_, up_)

    @one_blas_thread
    def supports(self, dirs: np.ndarray, below: np.ndarray | None = None,
                 outer: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """max over the pool's polytope of d^T x for each row d of ``dirs`` (see :func:`supports`)."""
        return supports(self, dirs, below, outer)

    @one_blas_thread
    def reaches(self, dirs: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """For each row d of ``dirs`` (k, n_cols) a point of the pool's polytope with d^T x >= its
        target, or the maximiser (see :func:`reaches`)."""
        return reaches(self, dirs, targets)


def supports(lp, dirs: np.ndarray, below: np.ndarray | None = None,
             outer: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """max over the polytope of ``lp`` (a :class:`WorkingSetLP`) of d^T x
    for each row d of ``dirs`` (k, n_cols).

    Returns (values (k,), vertices (v, n_cols), which (k,) index of the maximising vertex).
    One LP per distinct optimal basis: after each LP, every pending direction inside the
    normal cone of its basis (of the next CONE_WINDOW pending ones, or all of them with ``below``)
    is answered by the same vertex (exactly, no LP).

    ``below`` (k,): only whether each support is below ``below`` is wanted. After each LP,
    every pending d = N^T lam (N the basis's normals) gets the bound
    sum_{lam_j > 0} lam_j own_j + sum_{lam_j < 0} |lam_j| opp_j >= its support (LP duality,
    from the two sides of each basic constraint, or from ``outer``, a box (lo, hi) known to
    contain the polytope); a direction whose bound falls below ``below`` is settled without
    an LP: its value is that bound and ``which`` is -1. The LPs take the pending directions in
    order (neighbours in the data are often neighbours on the polytope: warm starts).
    """
    return _supports(lp, np.atleast_2d(np.asarray(dirs, dtype=float)), below, outer, None)[:3]


def reaches(lp, dirs: np.ndarray, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For each row d of ``dirs`` (k, n_cols): a point of the polytope of ``lp`` with d^T x >= its
    ``targets`` entry (k,) if the support reaches it, else the maximiser.

    Returns (values (k,), vertices (v, n_cols), which (k,), exact (k,)): values[i] = d_i^T of
    vertex which[i]; exact[i] True when that is the support, False when it is only a point at or
    beyond the target (a lower bound of the support). Each LP's simplex stops at the first vertex
    of the polytope beyond its target (:meth:`WorkingSetLP.reach`); every vertex found settles the
    pending directions whose target it reaches, and an optimal one also those in its normal cone
    (:func:`supports`), so a target that asks little costs a few simplex steps.
    """
    dirs = np.atleast_2d(np.asarray(dirs, dtype=float))
    return _supports(lp, dirs, None, None, np.broadcast_to(np.asarray(targets, dtype=float), dirs.shape[:1]))


def _in_threads(engines: list[WorkingSetLP], k: int, work) -> tuple[list[np.ndarray], list]:
    """Split the indices 0..k-1 in order between ``engines`` (clones over one pool,
    :meth:`WorkingSetLP.clone`; each takes the first one's active part of the pool) and run
    ``work(engine, indices)`` for each share in a thread of its own (the vertex simplex releases the
    GIL); afterwards every engine takes the working-set rows the others added. Returns (the shares,
    their results). The split is fixed, so the answers do not depend on the threads' timing."""
    parts = [idx for idx in np.array_split(np.arange(k), len(engines)) if idx.size]
    for eng in engines[1:]:
        eng.active = list(engines[0].active)
    with ONE_BLAS_THREAD, ThreadPoolExecutor(len(parts)) as pool:
        outs = list(pool.map(work, engines, parts))
    for a in engines:
        for b in engines:
            if a is not b:
                a.take_rows(b)
    return parts, outs


def minimize_in_threads(engines: list[WorkingSetLP], costs: np.ndarray) -> np.ndarray:
    """:meth:`WorkingSetLP.minimize_many` with the objectives shared between ``engines``
    (:func:`_in_threads`). Returns the argmins (k, n_cols) in the order of ``costs``: the same optimal
    values as on one engine (where an optimum is not unique, another optimal vertex may answer)."""
    costs = np.atleast_2d(np.asarray(costs, dtype=float))
    parts, outs = _in_threads(engines, len(costs), lambda eng, idx: eng._minimize(costs[idx])[0])
    X = np.empty((len(costs), costs.shape[1]))
    for idx, Xi in zip(parts, outs, strict=True):
        X[idx] = Xi
    return X


def reaches_in_threads(engines: list[WorkingSetLP], dirs: np.ndarray, targets: np.ndarray):
    """:func:`reaches` with the directions shared between ``engines`` (:func:`_in_threads`); targets
    +inf ask for the supports (:func:`supports`). The same supports as on one engine (where several
    vertices are optimal, another may answer); a point past a target may be another one, since each
    engine starts from its own remembered vertices."""
    dirs = np.atleast_2d(np.asarray(dirs, dtype=float))
    targets = np.broadcast_to(np.asarray(targets, dtype=float), dirs.shape[:1])
    parts, outs = _in_threads(engines, len(dirs),
                              lambda eng, idx: _supports(eng, dirs[idx], None, None, targets[idx]))
    values, exact = np.empty(len(dirs)), np.empty(len(dirs), dtype=bool)
    which, verts, start = np.empty(len(dirs), dtype=np.int64), [], 0
    for idx, (v, V, w, ex) in zip(parts, outs, strict=True):
        values[idx], exact[idx], which[idx] = v, ex, w + start
        verts.append(V)
        start += len(V)
    return values, np.vstack(verts), which, exact


def _supports(lp, dirs, below, outer, targets):
    """(values, vertices, which, exact) of :func:`supports` (``targets`` None) and :func:`reaches`."""
    k = dirs.shape[0]
    values, which, verts = np.full(k, np.nan), np.full(k, -1, dtype=np.int64), []
    exact = np.zeros(k, dtype=bool)
    ub = np.full(k, np.inf)
    pending = np.arange(k)
    while pending.size:
        i = pending[0]
        if targets is not None and np.isfinite(targets[i]):
            x, reached = lp.reach(-dirs[i], -targets[i])
        else:
            x, reached = lp.minimize_many(-dirs[i][None, :])[0], False
        verts.append(x)
        covered = pending == i
        screened = np.zeros(pending.size, dtype=bool)
        found = None if reached else lp.active_normals(x)
        if found is not None:
            N, own, opp = found
            near = pending if below is not None else pending[:CONE_WINDOW]
            try:
                lam = np.linalg.solve(N.T, dirs[near].T)
            except np.linalg.LinAlgError:
                lam = None
            if lam is not None:
                scale = np.linalg.norm(dirs[near], axis=1)
                covered[:near.size] |= np.all(lam >= -_CONE_TOL * scale, axis=0)
                if below is not None:
                    if outer is not None:           # -n^T x over the box, for each normal n
                        opp = np.minimum(opp, np.maximum(-N * outer[0], -N * outer[1]).sum(axis=1))
                    with np.errstate(invalid="ignore"):
                        bound = np.where(lam > 0, lam * own[:, None], -lam * opp[:, None]).sum(axis=0)
                    ub[pending] = np.minimum(ub[pending], np.where(np.isnan(bound), np.inf, bound))
                    screened = ~covered & (ub[pending] < below[pending])
        exact[pending[covered]] = not reached
        if targets is not None:                     # a point of the polytope beyond a target settles it
            covered |= dirs[pending] @ x >= targets[pending]
        values[pending[covered]] = dirs[pending[covered]] @ x
        which[pending[covered]] = len(verts) - 1
        values[pending[screened]] = ub[pending[screened]]
        pending = pending[~covered & ~screened]
    return values, np.array(verts), which, exact


def _highs_rows(h: highspy.Highs, vals: np.ndarray, lo: np.ndarray, up: np.ndarray) -> None:
    """Append dense rows lo <= vals x <= up to the HiGHS model h (+-inf allowed: highspy.kHighsInf is inf)."""
    m, n = vals.shape
    if m == 0:
        return
    idx = np.broadcast_to(np.arange(n, dtype=np.int32), (m, n)).ravel()
    starts = np.arange(m, dtype=np.int32) * n
    h.addRows(m, lo, up, vals.size, starts, idx, np.ascontiguousarray(vals, dtype=float).ravel())
