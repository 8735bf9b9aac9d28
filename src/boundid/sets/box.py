"""Boxes (orthotopes) B = {x : lo <= x <= hi}, the set of interval analysis."""

from __future__ import annotations

import numpy as np

from boundid._validation import as_float_array, as_matrix, as_vector
from boundid.errors import InputError
from boundid.sets._plane import closed, plane, require_2d


class Box:
    """The axis-aligned box {x : lo <= x <= hi} in R^p.

    Parameters
    ----------
    lo, hi : (p,) arrays
        Lower and upper bounds (parameter units), finite, lo <= hi (lo = hi allowed: a flat box).

    ``center`` and ``half_widths`` are (lo + hi) / 2 and (hi - lo) / 2, or, for a box made by
    :meth:`from_center`, the values given there, exactly (lo and hi are then their rounded sum
    and difference).
    """

    __slots__ = ("lo", "hi", "_center", "_half")

    def __init__(self, lo, hi):
        self.lo = as_vector(lo, "lo").copy()
        self.hi = as_vector(hi, "hi", self.lo.shape[0]).copy()
        if np.any(self.lo > self.hi):
            raise InputError(f"a box needs lo <= hi; violated at indices {np.flatnonzero(self.lo > self.hi)}.")
        self._center = 0.5 * (self.lo + self.hi)
        self._half = 0.5 * (self.hi - self.lo)

    @classmethod
    def from_center(cls, center, half_widths) -> Box:
        """The box center +- half_widths (a scalar half-width is used on every axis)."""
        c = as_vector(center, "center")
        h = np.broadcast_to(as_float_array(half_widths, "half_widths"), c.shape).astype(float)
        if np.any(h < 0) or not np.all(np.isfinite(h)):
            raise InputError("half_widths must be finite and >= 0.")
        box = cls(c - h, c + h)
        box._center, box._half = c.copy(), h.copy()
        return box

    @property
    def dim(self) -> int:
        return self.lo.shape[0]

    @property
    def center(self) -> np.ndarray:
        """(p,) centre (a copy)."""
        return self._center.copy()

    @property
    def half_widths(self) -> np.ndarray:
        """(p,) half-widths (a copy)."""
        return self._half.copy()

    def intervals(self) -> tuple[np.ndarray, np.ndarray]:
        return self.lo.copy(), self.hi.copy()

    def support(self, direction) -> float:
        """max over B of d^T x = d^T c + |d|^T h (c centre, h half-widths)."""
        d = as_vector(direction, "direction", self.dim)
        return float(d @ self.center + np.abs(d) @ self.half_widths)

    def supports(self, directions) -> np.ndarray:
        """max over B of d^T x for each row d of ``directions`` (m, p)."""
        D = as_matrix(directions, "directions", self.dim)
        return D @ self.center + np.abs(D) @ self.half_widths

    def gauge(self, points) -> np.ndarray | float:
        """max_j |x_j - c_j| / h_j for each point (<= 1 inside; inf off a flat side)."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.abs(X - self.center) / self.half_widths
        g = np.max(np.where(np.abs(X - self.center) == 0, 0.0, r), axis=1)
        return float(g[0]) if np.ndim(points) == 1 else g

    def contains(self, points, rtol: float = 1e-9) -> np.ndarray | bool:
        """Whether each point lies in B, allowing rtol times each side's length (and the rounding
        of the bounds themselves) outside."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        tol = rtol * (self.hi - self.lo) + 8 * np.finfo(float).eps * np.maximum(np.abs(self.lo), np.abs(self.hi))
        ok = np.all((X >= self.lo - tol) & (X <= self.hi + tol), axis=1)
        return bool(ok[0]) if np.ndim(points) == 1 else ok

    def log_volume(self) -> float:
        """sum_j ln(hi_j - lo_j); -inf for a flat box."""
        with np.errstate(divide="ignore"):
            return float(np.sum(np.log(self.hi - self.lo)))

    def project(self, i: int, j: int) -> Box:
        """The box of coordinates (i, j) (the shadow of a box is a box)."""
        idx = plane(i, j, self.dim)
        return Box(self.lo[idx], self.hi[idx])

    def boundary(self, n_points: int = 200) -> np.ndarray:
        """The four corners of a 2-D box, counter-clockwise, closed (5, 2)."""
        require_2d(self.dim, "box")
        (a, b), (c, d) = self.lo, self.hi
        return closed(np.array([[a, b], [c, b], [c, d], [a, d]]))

    def __repr__(self) -> str:
        return f"Box(dim={self.dim}, log_volume={self.log_volume():.4g})"
