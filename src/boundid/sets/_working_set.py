"""Constraint generation for LPs with many rows (HiGHS dual simplex, warm-started).

A large LP  min c^T x  s.t.  lo_i <= a_i^T x + g_i s <= up_i  (i in a pool of up to ~1e6 rows)
is solved on a small working set of rows; after each solve one matrix-vector pass over the
whole pool finds the most violated rows, which are added, and HiGHS re-solves from its last
basis (a row added to an optimal basis keeps it dual feasible, so the dual simplex needs few
iterations). It stops when no pool row is violated: the working-set optimum is then feasible
for the full LP and optimal for it (the working set is a relaxation). Changing the objective
keeps the basis too (primal simplex), so the 2p objectives of a bounding box share the work.

The pool is a list of blocks that may share one matrix: block b holds rows ``A_b`` (m_b, p) on
the first p columns, an optional coefficient vector ``g_b`` (m_b,) on one extra column (the
Chebyshev radius or the consistency level), and row bounds ``lo_b``, ``up_b`` (+-inf allowed).
"""

from __future__ import annotations

from dataclasses import dataclass

import highspy
import numpy as np

from boundid.errors import SolverError

_INF = highspy.kHighsInf
_STATUS = highspy.HighsModelStatus


@dataclass
class Block:
    """Rows lo <= A x[:p] + g x[p] <= up of the pool (``g`` None: no extra column)."""

    A: np.ndarray
    lo: np.ndarray
    up: np.ndarray
    g: np.ndarray | None = None

    def activity(self, x: np.ndarray) -> np.ndarray:
        r = self.A @ x[: self.A.shape[1]]
        if self.g is not None:
            r = r + self.g * x[self.A.shape[1]]
        return r

    def violation(self, x: np.ndarray) -> np.ndarray:
        """max(lo - a^T x, a^T x - up), less a rounding allowance of 1e-13 |bound|."""
        r = self.activity(x)
        with np.errstate(invalid="ignore"):
            v_lo = self.lo - r - 1e-13 * np.abs(self.lo)
            v_up = r - self.up - 1e-13 * np.abs(self.up)
        return np.fmax(np.nan_to_num(v_lo, nan=-np.inf, neginf=-np.inf),
                       np.nan_to_num(v_up, nan=-np.inf, neginf=-np.inf))


class LPStatusError(Exception):
    """The working-set LP is infeasible or unbounded (``status`` says which)."""

    def __init__(self, status: str):
        super().__init__(status)
        self.status = status


class WorkingSetLP:
    """A HiGHS model over ``n_cols`` columns whose rows are generated from ``blocks``.

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
        Violation (in the row's units; strips are normalised to half-width 1) below which a pool
        row counts as satisfied.
    batch : int
        At most this many of the most violated rows are added per round.
    """

    def __init__(self, blocks, col_lo, col_hi, seed=(), tol: float = 1e-9, batch: int = 32,
                 max_rounds: int = 10_000):
        self.blocks = list(blocks)
        self.n_cols = len(col_lo)
        self.tol = tol
        self.batch = batch
        self.max_rounds = max_rounds
        self.in_ws = [np.zeros(b.A.shape[0], dtype=bool) for b in self.blocks]
        self.row_of = [np.full(b.A.shape[0], -1, dtype=np.int64) for b in self.blocks]
        self.n_rows = 0
        self.n_solves = 0
        h = highspy.Highs()
        for name, val in (("output_flag", False), ("presolve", "off"), ("solver", "simplex"),
                          ("primal_feasibility_tolerance", 1e-10), ("dual_feasibility_tolerance", 1e-10),
                          ("threads", 1)):
            h.setOptionValue(name, val)
        lo = np.where(np.isfinite(col_lo), col_lo, -_INF).astype(float)
        hi = np.where(np.isfinite(col_hi), col_hi, _INF).astype(float)
        h.addVars(self.n_cols, lo, hi)
        self.h = h
        for b, rows in seed:
            self.add_rows(b, np.asarray(rows, dtype=np.int64))

    def add_rows(self, b: int, rows: np.ndarray) -> None:
        """Add pool rows ``rows`` of block ``b`` to the working set (duplicates skipped)."""
        rows = np.unique(rows)
        rows = rows[~self.in_ws[b][rows]]
        if rows.size == 0:
            return
        blk = self.blocks[b]
        vals = blk.A[rows]
        if blk.g is not None:
            vals = np.hstack([vals, blk.g[rows, None]])
        ncol = vals.shape[1]
        idx = np.tile(np.arange(ncol, dtype=np.int32), rows.size)
        starts = np.arange(rows.size, dtype=np.int32) * ncol
        lo = np.where(np.isfinite(blk.lo[rows]), blk.lo[rows], -_INF)
        up = np.where(np.isfinite(blk.up[rows]), blk.up[rows], _INF)
        self.h.addRows(rows.size, lo, up, vals.size, starts, idx, vals.ravel().astype(float))
        self.in_ws[b][rows] = True
        self.row_of[b][rows] = np.arange(self.n_rows, self.n_rows + rows.size)
        self.n_rows += rows.size

    def set_bounds(self, b: int, k: int, lo: float, up: float) -> None:
        """Change the bounds of pool row k of block b (and of its working-set copy)."""
        blk = self.blocks[b]
        blk.lo[k], blk.up[k] = lo, up
        r = self.row_of[b][k]
        if r >= 0:
            self.h.changeRowBounds(int(r), lo if np.isfinite(lo) else -_INF, up if np.isfinite(up) else _INF)

    def _worst(self, x: np.ndarray) -> list[tuple[int, np.ndarray]]:
        """The ``batch`` most violated pool rows (above tol) not yet in the working set, per block
        (rows in it are HiGHS's to satisfy, to its own tolerance)."""
        cand = []
        for b, blk in enumerate(self.blocks):
            v = blk.violation(x)
            hit = np.flatnonzero((v > self.tol) & ~self.in_ws[b])
            if hit.size:
                cand.append((b, hit, v[hit]))
        if not cand:
            return []
        allv = np.concatenate([c[2] for c in cand])
        if allv.size > self.batch:
            cut = np.partition(allv, allv.size - self.batch)[allv.size - self.batch]
        else:
            cut = -np.inf
        return [(b, hit[vv >= cut]) for b, hit, vv in cand]

    def minimize(self, cost: np.ndarray) -> tuple[np.ndarray, float]:
        """argmin and min of cost^T x over the full pool (cost: (n_cols,))."""
        h = self.h
        h.changeColsCost(self.n_cols, np.arange(self.n_cols, dtype=np.int32), np.asarray(cost, dtype=float))
        for _ in range(self.max_rounds):
            h.run()
            self.n_solves += 1
            st = h.getModelStatus()
            if st == _STATUS.kInfeasible:
                raise LPStatusError("infeasible")
            if st in (_STATUS.kUnbounded, _STATUS.kUnboundedOrInfeasible):
                raise LPStatusError("unbounded" if st == _STATUS.kUnbounded else "unbounded_or_infeasible")
            if st != _STATUS.kOptimal:
                raise SolverError(f"HiGHS stopped with status {h.modelStatusToString(st)} on a "
                                  f"{self.n_rows}-row working set; the problem may be badly scaled.")
            x = np.array(h.getSolution().col_value)
            worst = self._worst(x)
            if not worst:
                return x, float(cost @ x)
            for b, rows in worst:
                self.add_rows(b, rows)
        raise SolverError(f"constraint generation did not converge in {self.max_rounds} rounds.")
