"""Parallelotopes P = c ⊕ G B^p with G square and invertible ([VicinoZappa1996]).

A parallelotope is the zonotope with p independent generators, and also the intersection of p
strips, P = {x : |T (x - c)|_inf <= 1} with T = G^-1. It is its own class (a subclass of
:class:`~boundid.sets.zonotope.Zonotope`) because that strip form gives what a general zonotope
lacks: membership in O(p^2) without an LP, and the exact volume 2^p |det G| in O(p^3). Its
shadow on a plane is a zonogon with up to p generators (a parallelogram only when p = 2), so
``project`` returns a Zonotope.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from boundid._validation import as_float_array, as_vector
from boundid.errors import InputError
from boundid.sets.box import Box
from boundid.sets.zonotope import Zonotope


class Parallelotope(Zonotope):
    """The parallelotope {c + G xi : |xi|_inf <= 1}, G (p, p) invertible.

    Parameters
    ----------
    center : (p,) array
        Centre c (parameter units).
    generators : (p, p) array
        Invertible generator matrix G (columns: half-edge vectors, parameter units).
    """

    __slots__ = ("_lu",)

    def __init__(self, center, generators):
        super().__init__(center, generators)
        p, m = self.generators.shape
        if m != p:
            raise InputError(f"a parallelotope needs a square (p, p) generator matrix, got {self.generators.shape}; "
                             "use Zonotope for other generator counts.")
        sv = np.linalg.svd(self.generators, compute_uv=False)
        if not sv[-1] > 1e-14 * sv[0]:
            raise InputError(f"the generator matrix is singular (condition number {sv[0] / max(sv[-1], 1e-300):.3g}): "
                             "a flat parallelotope has no strip form; use Zonotope.")
        self._lu = scipy.linalg.lu_factor(self.generators)

    @classmethod
    def from_box(cls, box: Box) -> Parallelotope:
        """The box as a parallelotope (G = diag of its half-widths, all > 0)."""
        if np.any(box.half_widths <= 0):
            raise InputError("a parallelotope needs every half-width > 0; the box is flat.")
        return cls(box.center, np.diag(box.half_widths))

    @classmethod
    def from_strips(cls, normals, mid, half) -> Parallelotope:
        """{x : |n_k^T x - mid_k| <= half_k, k = 1..p} for p independent normals n_k (rows of
        ``normals``, (p, p)) and half-widths half_k > 0: c = N^-1 mid, G = N^-1 diag(half)."""
        N = as_float_array(normals, "normals")
        if N.ndim != 2 or N.shape[0] != N.shape[1]:
            raise InputError(f"normals must be a square (p, p) matrix, got shape {N.shape}.")
        p = N.shape[0]
        mid = as_vector(mid, "mid", p)
        half = as_vector(half, "half", p)
        if np.any(half <= 0):
            raise InputError("every strip half-width must be > 0.")
        return cls(np.linalg.solve(N, mid), np.linalg.solve(N, np.diag(half)))

    def normalized(self, points) -> np.ndarray:
        """T (x - c) = G^-1 (x - c) for each point (rows (m, p)): the point's coordinates in the
        unit box of P (inside iff every |entry| <= 1)."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        return scipy.linalg.lu_solve(self._lu, (X - self.center).T).T

    def gauge(self, points) -> np.ndarray | float:
        """|T (x - c)|_inf for each point: its largest coordinate in P's unit box (<= 1 inside)."""
        g = np.max(np.abs(self.normalized(points)), axis=1)
        return float(g[0]) if np.ndim(points) == 1 else g

    def contains(self, points, rtol: float = 1e-9) -> np.ndarray | bool:
        """|T (x - c)|_inf <= 1 + rtol (rtol relative to P's own half-widths), plus the rounding
        of the coordinates themselves, |T| 8 eps (|x| + |c| + sum_k |G_jk|) (it matters only for
        a parallelotope that is thin next to |c| or to its own largest side, such as a feasible
        set shrunk to a point)."""
        X = np.atleast_2d(as_float_array(points, "points"))
        Z = self.normalized(X)
        T = scipy.linalg.lu_solve(self._lu, np.eye(self.dim))
        slack = (8 * np.finfo(float).eps * (np.abs(X) + np.abs(self.center) + self.radii())) @ np.abs(T).T
        ok = np.all(np.abs(Z) <= 1.0 + rtol + slack, axis=1)
        return bool(ok[0]) if np.ndim(points) == 1 else ok

    def log_volume(self) -> float:
        """ln vol(P) = p ln 2 + ln |det G|."""
        return float(self.dim * np.log(2.0) + np.sum(np.log(np.abs(np.diag(self._lu[0])))))

    def __repr__(self) -> str:
        return f"Parallelotope(dim={self.dim}, log_volume={self.log_volume():.4g})"
