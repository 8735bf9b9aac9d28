"""Polytope recursions: the exact feasible set for p <= 4, and a limited-complexity one for any p.

* :class:`PolytopeRecursion` ([WalterPietLahanier1989], [MoNorton1990]): the feasible set itself,
  kept as vertices and facets (double description) and cut by the two sides of every strip.
  Exact (up to the outward rounding guard of every step), practical for p <= 4 (the vertex count
  grows with the number of facets).
* :class:`LimitedPolytopeRecursion`: for any p, keeps at most K strips and the current bounding
  box; after each block of samples it takes the exact bounds of (kept strips ∩ block ∩ box) by
  LP ([refs §LP], :meth:`boundid.sets.Polytope.bounds`) and keeps the K strips nearest to active
  at the 2p bound vertices (the working set that decides the bounds).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from boundid.errors import InputError
from boundid.estimators import _set_kernels as K
from boundid.estimators._set_recursion import Run, SetRecursion, clip_strip, fit_problem
from boundid.estimators.method import Method, NoOptions, Style, option
from boundid.sets.box import Box
from boundid.sets.polytope import Polytope
from boundid.sets.vertex_polytope import VertexPolytope

#: largest dimension the exact recursion accepts
MAX_EXACT_DIM = 4
#: the limited polytope widens each strip by this fraction of its bound, and each LP bound by
#: this fraction of the old and new box widths: above the LP's tolerances (1e-9 of a strip's
#: half-width, 1e-10 of the box), so that a feasible set shrunk to a point (errors exactly at
#: the bounds) stays feasible for the LP and inside every box
LP_GUARD = 1e-8
#: least clipped half-width of a strip in the limited polytope's LP, relative to the box's
#: extent along the strip (keeps the LP's coefficients below 1 / LP_FLOOR)
LP_FLOOR = 1e-7


class DoubleDescription:
    """A bounded polytope {x : A x <= b} with its vertices and the vertex-facet incidence.

    Kept relative to an origin x0 (the vertex centroid, moved after every cut) so that rounding
    scales with the polytope's size, not with |x|: V (n, p) vertices minus x0, A (k, p) unit-norm
    facet normals, b (k,) = the facets' offsets minus A x0, inc (n, k) bool: vertex i lies on
    facet j. The incidence is kept combinatorially (new vertices inherit it), never recomputed
    from rounded coordinates.
    """

    def __init__(self, lo: np.ndarray, hi: np.ndarray):
        p = lo.shape[0]
        corners = np.array(np.meshgrid(*[[0, 1]] * p, indexing="ij")).reshape(p, -1).T.astype(bool)
        self.x0 = 0.5 * (lo + hi)
        h = 0.5 * (hi - lo)
        self.V = np.where(corners, h, -h)
        self.A = np.vstack([np.eye(p), -np.eye(p)])
        self.b = np.concatenate([h, h])
        self.inc = np.hstack([corners, ~corners])

    def extent(self, w: np.ndarray) -> tuple[float, float]:
        """(min, max) of w^T x over the polytope."""
        proj = self.V @ w
        m0 = float(w @ self.x0)
        return m0 + float(proj.min()), m0 + float(proj.max())

    @property
    def dim(self) -> int:
        return self.V.shape[1]

    def cut(self, a: np.ndarray, beta: float) -> int:
        """Intersect with {x : a^T x <= beta} (a unit norm) in place. Returns the number of
        vertices cut off (0: the halfspace is redundant; nothing changes).

        Vertices with |a^T v - beta| <= tol count as on the plane (kept, incident to the new
        facet); tol = 16 eps (max |a^T v| + |beta|) in the relative coordinates, the rounding of
        that product: a looser tolerance would leave vertices off their facets, an error that
        grows relative to the polytope as it shrinks. Each pair (inside vertex,
        outside vertex) that is adjacent gives a new vertex where its edge crosses the plane
        (:meth:`_vertex`).
        Adjacency test (combinatorial, valid with degenerate vertices): the facets the two share
        are at least p - 1 and no third vertex lies on all of them. Facets left with fewer than
        p vertices are dropped (no longer facets).
        """
        p = self.dim
        beta = beta - float(a @ self.x0)
        Va = self.V @ a
        s = Va - beta
        tol = 16 * np.finfo(float).eps * (float(np.abs(Va).max()) + abs(beta))
        out = s > tol
        if not out.any():
            return 0
        inn = s < -tol
        inc = self.inc.astype(np.int64)
        ii, oo = np.flatnonzero(inn), np.flatnonzero(out)
        shared = inc[ii] @ inc[oo].T
        new_V, new_inc = [], []
        for a_i, a_o in zip(*np.nonzero(shared >= p - 1), strict=True):
            i, o = ii[a_i], oo[a_o]
            common = self.inc[i] & self.inc[o]
            if np.count_nonzero(inc[:, common].sum(axis=1) == common.sum()) != 2:
                continue
            new_V.append(self._vertex(common, a, beta, self.V[i], self.V[o], s[i], s[o]))
            new_inc.append(common)
        keep = ~out
        on = keep & ~inn
        V = np.vstack([self.V[keep]] + ([np.array(new_V)] if new_V else []))
        I_old = np.hstack([self.inc[keep], on[keep][:, None]])
        I_new = np.hstack([np.array(new_inc).reshape(-1, self.inc.shape[1]), np.ones((len(new_V), 1), bool)])
        inc_all = np.vstack([I_old, I_new])
        facet = inc_all.sum(axis=0) >= p
        A, b = np.vstack([self.A, a])[facet], np.append(self.b, beta)[facet]
        shift = V.mean(axis=0)
        self.x0 = self.x0 + shift
        self.V, self.A, self.b = V - shift, A, b - A @ shift
        self.inc = inc_all[:, facet]
        return int(out.sum())

    def _vertex(self, common, a, beta, vi, vo, si, so) -> np.ndarray:
        """The new vertex on edge (vi, vo): the solution of its facets' equations, A_F x = b_F
        (F = the edge's facets and the new one), so that rounding does not accumulate from
        vertex to vertex; the edge interpolation vi + si / (si - so) (vo - vi) if those
        equations are rank deficient in floating point."""
        AF = np.vstack([self.A[common], a])
        bF = np.append(self.b[common], beta)
        x, _, rank, sv = np.linalg.lstsq(AF, bF, rcond=None)
        if rank == self.dim and sv[-1] > 1e-10 * sv[0]:
            return x
        return vi + si / (si - so) * (vo - vi)

    def to_set(self) -> VertexPolytope:
        return VertexPolytope(self.x0 + self.V, facets=(self.A, self.b + self.A @ self.x0))


class PolytopeRecursion(SetRecursion):
    """The exact recursive feasible polytope, p <= 4 (double description).

    Each strip, guarded and clipped to the polytope's extent along w like every family, cuts
    the vertex/facet description with its two sides. The set is the feasible set itself (to
    the 1e-12 outward rounding guard and the 1e-8 floor on clipped strip widths). Cost per
    update: O(n_in n_out k) for the adjacency test (n vertices, k facets); a strip that does not
    cut costs O(n p). The history's ln volume is Qhull's.

    Parameters: see :class:`~boundid.estimators._set_recursion.SetRecursion` (p <= 4, the prior box
    ``prior`` (or center0, shape0), ``on_outlier``, ``record_every``, ``names``).
    """

    method = "Exact polytope recursion"

    def __init__(self, p: int, **kwargs):
        if isinstance(p, int | np.integer) and p > MAX_EXACT_DIM:
            raise InputError(f"the exact polytope recursion keeps every vertex: p <= {MAX_EXACT_DIM} only "
                             f"(p = {p}); use LimitedPolytopeRecursion for larger p.")
        super().__init__(p, **kwargs)

    def _start(self) -> None:
        self.dd = DoubleDescription(*self.prior.intervals())
        self._record = None  # (centre, ln volume) of the current polytope, once computed

    def _run(self, W, y, e, k0) -> Run:
        N = W.shape[0]
        b = self._buffers(N)
        n_upd = n_skip = n_out = n_rec = 0
        processed = N
        countdown = self.record_every - k0 % self.record_every
        for i in range(N):
            w = W[i]
            lo, hi = self.dd.extent(w)
            m, r = 0.5 * (lo + hi), 0.5 * (hi - lo)
            status, yc, sc = clip_strip(float(y[i]), float(e[i]), m, r, float(np.abs(w * self.dd.x0).sum()))
            if status == K.OUTLIER:
                b["out_idx"][n_out], b["out_res"][n_out] = k0 + i, y[i] - m
                n_out += 1
                if self._stop:
                    processed = i
                    break
            elif status == K.NO_INFO:
                n_skip += 1
            else:
                nw = float(np.linalg.norm(w))
                cut = self.dd.cut(w / nw, (yc + sc) / nw) + self.dd.cut(-w / nw, -(yc - sc) / nw)
                n_upd += cut > 0
                n_skip += cut == 0
                if cut:
                    self._record = None
            countdown -= 1
            if countdown == 0 or i == N - 1:
                countdown = countdown or self.record_every
                if self._record is None:  # the polytope changed since the last record
                    S = self.dd.to_set()
                    lo_, hi_ = S.intervals()
                    self._record = (0.5 * (lo_ + hi_), S.log_volume())
                b["hist_idx"][n_rec] = k0 + i
                b["hist_c"][n_rec], b["hist_lv"][n_rec] = self._record
                n_rec += 1
        b["counts"][:] = processed, n_upd, n_skip, n_out, n_rec
        return self._collect(b)

    def current_set(self) -> VertexPolytope:
        return self.dd.to_set()

    def _info(self) -> dict:
        return {"n_vertices": len(self.dd.V), "n_facets": len(self.dd.b)}


class LimitedPolytopeRecursion(SetRecursion):
    """A polytope of at most ``max_strips`` strips and a box, bounded by LP after each block.

    State: the kept strips and the box [lo, hi] (the prior box, then the last bounds). After
    each block of ``block`` samples (and at the end of every ``partial_fit`` call):

    1. a block row whose strip misses the box is an outlier (skipped or raised);
    2. Q = (kept strips) ∩ (block strips that cut the box) ∩ box contains the truth, and its
       exact bounds (2p LPs, warm-started, with constraint generation, in the box's frame:
       :meth:`_block_lp`) become the new box; strips and bounds are widened by LP_GUARD (1e-8,
       relative), above the LP tolerances;
    3. the ``max_strips`` strips of Q with the least slack at the 2p bound vertices are kept
       (slack 1 - |w^T v - y| / e at the vertex v where the strip is nearest to active).

    The box never widens, and every box contains the feasible set, so the truth stays inside.
    With all strips kept (max_strips >= N) the box is the exact LP box of the data.

    Parameters
    ----------
    max_strips : int, default 4p
        K, the most strips kept between blocks.
    block : int, default 100p
        Samples per LP block. Each block builds a new LP, so larger blocks cost less per sample;
        reports/benchmarks/families.md measures the defaults against the batch LP.

    Other parameters: see :class:`~boundid.estimators._set_recursion.SetRecursion`; the history
    has one record per block (``record_every`` is not used) and NaN ln volumes. The set is a
    :class:`~boundid.sets.Polytope` (kept strips and the box).
    """

    def __init__(self, p: int, *, max_strips: int | None = None, block: int | None = None, **kwargs):
        for name, val in (("max_strips", max_strips), ("block", block)):
            if val is not None and not (isinstance(val, int | np.integer) and val >= 1):
                raise InputError(f"{name} must be a positive integer, got {val!r}.")
        self.max_strips = int(max_strips) if max_strips is not None else None
        self.block = int(block) if block is not None else None
        super().__init__(p, **kwargs)
        self.max_strips = self.max_strips or 4 * self.p
        self.block = self.block or 100 * self.p

    @property
    def method(self) -> str:
        return f"Limited polytope (K = {self.max_strips} strips, LP every {self.block} samples)"

    def _start(self) -> None:
        self.lo, self.hi = self.prior.intervals()
        self.Wk, self.yk, self.ek = np.zeros((0, self.p)), np.zeros(0), np.zeros(0)
        self.n_lps = 0

    def _run(self, W, y, e, k0) -> Run:
        N = W.shape[0]
        n_blocks = math.ceil(N / self.block)
        hist_idx, hist_c = np.empty(n_blocks, np.int64), np.empty((n_blocks, self.p))
        out_idx, out_res = [], []
        n_upd = n_skip = 0
        processed = N
        for nb, start in enumerate(range(0, N, self.block)):
            rows = np.arange(start, min(start + self.block, N))
            c, h = 0.5 * (self.lo + self.hi), 0.5 * (self.hi - self.lo)
            m, r = W[rows] @ c, np.abs(W[rows]) @ h
            guard = K.ROUND_GUARD * (np.abs(y[rows]) + e[rows] + np.abs(W[rows] * c).sum(axis=1) + r)
            s = e[rows] * (1 + LP_GUARD) + guard
            miss = np.abs(y[rows] - m) > s + r
            if miss.any():
                out_idx += (k0 + rows[miss]).tolist()
                out_res += (y[rows] - m)[miss].tolist()
                if self._stop:
                    processed = int(rows[np.argmax(miss)])
                    hist_idx, hist_c = hist_idx[:nb], hist_c[:nb]
                    break
            ok = rows[~miss]
            inside = np.abs(y[ok] - m[~miss]) + r[~miss] <= s[~miss]   # strips holding the whole box
            n_skip += int(inside.sum()) + int(miss.sum())
            new = ok[~inside]
            n_upd += new.size
            if new.size:
                self._block_lp(np.vstack([self.Wk, W[new]]), np.concatenate([self.yk, y[new]]),
                               np.concatenate([self.ek, s[~miss][~inside]]))
            hist_idx[nb], hist_c[nb] = k0 + rows[-1], 0.5 * (self.lo + self.hi)
        n_rec = len(hist_idx)
        return Run(processed, n_upd, n_skip, hist_idx, hist_c, np.full(n_rec, np.nan),
                   np.array(out_idx, np.int64), np.array(out_res))

    def _block_lp(self, W, y, e) -> None:
        """Bounds of (strips W, y, e) ∩ box by LP, solved in the box's frame theta = c + h z,
        z in [-1, 1]^p, an exact change of variables that keeps the LP well scaled however small
        the box is next to |theta|. In that frame each strip is clipped to the box's extent
        along it, [-r, r] with r = |h w|_1 (a strip that holds the whole box is dropped), and its
        clipped half-width floored at LP_FLOOR r (widening only), so that the LP's coefficients
        lie between 1 and 1 / LP_FLOOR."""
        c, h = 0.5 * (self.lo + self.hi), 0.5 * (self.hi - self.lo)
        Wz, yz = W * h, y - W @ c
        r = np.abs(Wz).sum(axis=1)
        lo_s, hi_s = np.maximum(yz - e, -r), np.minimum(yz + e, r)
        cut = (lo_s > -r) | (hi_s < r)
        if not cut.any():
            self.Wk, self.yk, self.ek = W[:0], y[:0], e[:0]
            return
        W, Wz, r = W[cut], Wz[cut], r[cut]
        yc, sc = 0.5 * (lo_s + hi_s)[cut], np.maximum(0.5 * (hi_s - lo_s)[cut], LP_FLOOR * r)
        b = Polytope(Wz, yc, sc, box=(-np.ones(self.p), np.ones(self.p))).bounds()
        self.n_lps += b.info["lp_solves"]
        lo, hi = c + h * b.lo, c + h * b.hi
        pad = LP_GUARD * (hi - lo + h) + 4 * np.finfo(float).eps * np.abs(c)
        self.lo = np.maximum(self.lo, lo - pad)
        self.hi = np.minimum(self.hi, hi + pad)
        slack = 1.0 - np.max(np.abs((b.vertices() @ Wz.T - yc) / sc), axis=0)
        keep = np.sort(np.argsort(slack, kind="stable")[: self.max_strips])
        self.Wk, self.yk, self.ek = W[keep], y[cut][keep], e[cut][keep]

    def current_set(self) -> Polytope | Box:
        """The kept strips and the box as a Polytope (the box alone before the first block)."""
        if len(self.yk) == 0:
            return Box(self.lo, self.hi)
        return Polytope(self.Wk, self.yk, self.ek, box=(self.lo, self.hi))

    def _intervals(self, S) -> tuple[np.ndarray, np.ndarray]:
        return self.lo.copy(), self.hi.copy()

    def _info(self) -> dict:
        return {"max_strips": self.max_strips, "block": self.block, "n_strips_kept": len(self.yk),
                "lp_solves": self.n_lps}


# ------------------------------------------------------------------------------ registry entries


@dataclass(frozen=True)
class LimitedPolytopeOptions:
    """What a study file may set for ``method = "polytope_limited"`` (None: the default of the class)."""

    max_strips: int | None = option(None, "K, the most strips kept between blocks (default 4 p)", lo=1)
    block: int | None = option(None, "samples per LP block (default 100 p)", lo=1)


EXACT_METHOD = Method(
    name="polytope_exact", summary=f"the exact recursive feasible polytope (double description, p <= {MAX_EXACT_DIM})",
    options=NoOptions, build=lambda pb, o: fit_problem(PolytopeRecursion, pb), set_family="polytope",
    kind="guaranteed", needs_bound=True, style=Style("#661100", "*", ":"))
LIMITED_METHOD = Method(
    name="polytope_limited", summary="limited-complexity polytope: K strips and a box, LP bounds after each block",
    options=LimitedPolytopeOptions, set_family="polytope", kind="guaranteed", needs_bound=True,
    build=lambda pb, o: fit_problem(LimitedPolytopeRecursion, pb, max_strips=o.max_strips, block=o.block),
    style=Style("#CC6677", "p", ":"))
